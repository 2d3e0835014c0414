"""Storage: every file sacflow reads or writes (case files, run files, surfaces, initial states).

The numerical layers below it do no I/O. Within the package, netCDF files are opened by the
storage modules :mod:`~sacflow.storage.run_layout` (creates run files and parts),
:mod:`~sacflow.storage.run_parts` (reads parts, consolidates them),
:mod:`~sacflow.storage.run_restart` (the solver state in a part),
:mod:`~sacflow.storage.run_reader` (``open_run``, ``run_info``, ``read_scalars``),
:mod:`~sacflow.storage.surface_file` (a measured surface in netCDF) and
:mod:`~sacflow.storage.initial_state_file` (the source run of a chained case),
:mod:`~sacflow.storage.fingerprints` (the ``case_id`` a source run stores); and, outside
this layer, by :mod:`sacflow.compare.reference` (a reference file that is
not a run; runs are opened through ``open_run``), :mod:`sacflow.compare.output` (writes a
comparison stage's result) and :mod:`sacflow.studies.dent_study` (reads run files and fatigue
results, writes the study's summary). The other comparison stages and
:mod:`sacflow.campaign.opening` open runs through ``open_run``. See ``docs/architecture.md``.
"""

# Installs the reader of the files a case's id covers (sacflow.config.identity): any use of
# the storage layer makes ``Case.case_id`` work for cases built without it.
from sacflow.storage import fingerprints as fingerprints
