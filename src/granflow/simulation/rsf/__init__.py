"""Rate-and-state friction: Dieterich, Ruina, Perrin-Rice-Zheng and Nagata laws on a spring.

``model`` (:class:`State`, :class:`RateState` and the steady states), ``pieces`` (a
protocol as linear pieces of load-point velocity, and the compiled run through them, shared
with :func:`granflow.rsf.fit`), ``simulate`` (a load-point velocity history from a
:class:`~granflow.Protocol`) and ``result`` (:class:`RateStateResult`). Public as
:mod:`granflow.rsf`.
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "model": ["LAWS", "RateState", "State"],
        "simulate": ["simulate"],
        "result": ["RateStateResult"],
    },
)
