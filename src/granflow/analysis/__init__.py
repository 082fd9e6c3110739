"""The main job: a campaign of instrument files in, tables, figures and a report out.

``engine`` (:func:`analyze` and the rules it follows), ``inputs`` (the campaign's runs and
their keys), ``runs`` (per-run analyses) returning the frozen values of ``run_results``;
``joint`` and ``predictions`` (analyses across runs, pure functions chained by ``stage``)
returning those of ``joint_results`` and ``prediction_results``; ``result``
(:class:`AnalysisResult`, whose ``to_dict()`` is ``results.json``); ``outputs`` (tables,
figures), ``files`` (file names, JSON), ``values`` (what the result types share);
``report``, ``report_views`` and ``formatting`` (the HTML report and its template: a leaf,
imported by the engine only inside a function) and ``demo`` (a synthetic campaign mirroring
the paper). Stands on :mod:`granflow.fitting`, :mod:`granflow.simulation`
and :mod:`granflow.io`.
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "engine": ["analyze", "classify", "startup_data"],
        "result": ["AnalysisResult", "RunEntry"],
        "run_results": [
            "CreepResult",
            "FailedRun",
            "RampResult",
            "StartupResult",
            "SwitchResult",
        ],
        "joint_results": ["Analyses", "Estimate", "Material"],
        "prediction_results": ["Predictions"],
        "demo": ["make_demo_campaign"],
        "report": ["render_report"],
    },
)
