"""Storage: every file sacflow reads or writes (case files, run files, surfaces, initial states).

The only layer that opens netCDF; the numerical layers below it do no I/O. See
``docs/architecture.md``.
"""

# Installs the reader of the files a case's id covers (sacflow.config.identity): any use of
# the storage layer makes ``Case.case_id`` work for cases built without it.
from sacflow.storage import fingerprints as fingerprints
