"""The incremental contact-plasticity solver: the increment, the load path, the body's state.

Takes plain parameters (no case schema) and yields one :class:`~sacflow.solver.state.State` per
increment; no I/O, no xarray. See ``docs/architecture.md``.
"""
