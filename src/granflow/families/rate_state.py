"""Rate-and-state friction: fits of velocity-step records (:func:`granflow.rsf.fit`), their
rows in :func:`granflow.compare_models`, and the campaign's velocity-step records
(``test: velocity_steps`` in a manifest; ``results.json``'s ``velocity_steps``, the
report's ``#velocity-steps``)."""

from granflow.families._seam import Family

FAMILY = Family(
    name="rate_state",
    description="rate-and-state friction on a spring, fitted to velocity steps",
    result_types=("granflow.fitting.rsf_result:RateStateFitResult",),
    models=("rsf_aging", "rsf_slip", "eq2_direct"),
    compare={
        "record": "granflow.fitting.rsf_compare:velocity_step_rows",
        "startup": "granflow.fitting.rsf_compare:startup_rows",
    },
    test_kind="velocity_steps",
    entries="granflow.analysis.velocity_steps:velocity_step_entries",
    analyse="granflow.analysis.velocity_steps:campaign_velocity_steps",
    results="granflow.analysis.velocity_steps:VelocitySteps",
    section="granflow.analysis.velocity_steps_report:velocity_steps_section",
)
