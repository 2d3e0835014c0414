"""Storage: every file sacflow reads or writes (case files, run files, surfaces, initial states).

The only layer that opens netCDF; the numerical layers below it do no I/O. See
``docs/architecture.md``.
"""
