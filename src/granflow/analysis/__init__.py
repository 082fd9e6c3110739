"""The main job: a campaign of instrument files in, tables, figures and a report out.

``engine`` (:func:`analyze` and the rules it follows), ``runs`` (per-run analyses), ``joint``
(analyses across runs, predictions), ``outputs`` (tables, figures), ``report`` (the HTML
report and its template) and ``demo`` (a synthetic campaign mirroring the paper). Stands on
:mod:`granflow.fitting`, :mod:`granflow.simulation` and :mod:`granflow.io`.
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "engine": ["AnalysisResult", "analyze", "classify", "startup_data"],
        "demo": ["make_demo_campaign"],
        "report": ["render_report"],
    },
)
