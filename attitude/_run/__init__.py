"""The run pipeline of :func:`attitude.propagate` and
:func:`attitude.ensemble.propagate_ensemble`: specification, plan, runner, results.

==============  ================================================================================
``spec``        :class:`RunSpec`: every input validated once (the checks an ensemble shares
                are its functions too), laid out as the runners' plain-float ``Problem``
``plan``        the planner: the method (``"auto"`` resolved, for a run or an ensemble), the
                runner or driver, the memory a result will take
``runner``      a run through its method: progress, compile notice, streaming, formulations
``results``     the RunResult to the Dataset (or Trajectory), or the PropagationError
==============  ================================================================================

The ensembles' chunked drivers and assembly are in :mod:`attitude.ensemble` (``_spec``,
``_runner``), which builds on ``spec`` and ``plan``.
"""
