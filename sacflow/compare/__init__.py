"""Comparison stages: stored runs (xarray Datasets) -> result Datasets, plots, files.

Each stage is a plain function of one or more runs (opened Datasets or run-file paths) returning
an :class:`xarray.Dataset` whose variables carry ``units`` and ``long_name``; 0-d variables are
its summary numbers, attribute ``stage`` names it. A stage's function has its command-line name,
hyphens written as underscores: ``sacflow compare load-approach RUN.nc`` is
``sacflow.compare.load_approach(run)``. Computation and plotting are separate:
``plots.plot(result)`` draws any result, :func:`write` stores ``stem.nc`` + ``stem.png``,
:func:`summary` prints the numbers. See ``docs/compare.md``.

=========================  ==============================  ==================================
stage and function         module                          seed / subject
=========================  ==============================  ==================================
``hertz_check``            :mod:`.hertz`                   Hertz, §3.2 Figs. 7–8
``indentation``            :mod:`.fields`                  Figs. 13–16
``load_approach``          :mod:`.hertz`                   Fig. 11
``elastic_vs_plastic``     :mod:`.pairs`                   Fig. 20
``vertical_vs_rolling``    :mod:`.pairs`                   Fig. 22
``track``                  :mod:`.rolling_track`           Fig. 18
``residual_map``           :mod:`.fields`                  Fig. 21
``fatigue``                :mod:`.fatigue_index`           Dang Van, Crossland
``passes``                 :mod:`.pass_history`            repeated rolling
``melan``                  :mod:`.melan_bound`             Melan's static shakedown theorem
``material_point``         :mod:`.material`                the case's material, cycled
``campaign_summary``       :mod:`.campaign`                campaigns
``case_vs_reference``      :mod:`.reference`               any reference data
=========================  ==============================  ==================================

Submodules are imported on first use, so that ``sacflow`` stays quick to start.
"""

from __future__ import annotations

from sacflow.lazy_exports import lazy_exports

__all__ = [
    "CompareError",
    "campaign_summary",
    "case_vs_reference",
    "elastic_vs_plastic",
    "fatigue",
    "hertz_check",
    "indentation",
    "load_approach",
    "material_point",
    "melan",
    "passes",
    "plot",
    "residual_map",
    "summary",
    "summary_numbers",
    "track",
    "vertical_vs_rolling",
    "write",
]

_EXPORTS = {
    "CompareError": "sacflow.compare.core",
    "campaign_summary": "sacflow.compare.campaign",
    "case_vs_reference": "sacflow.compare.reference",
    "elastic_vs_plastic": "sacflow.compare.pairs",
    "fatigue": "sacflow.compare.fatigue_index",
    "hertz_check": "sacflow.compare.hertz",
    "indentation": "sacflow.compare.fields",
    "load_approach": "sacflow.compare.hertz",
    "material_point": "sacflow.compare.material",
    "melan": "sacflow.compare.melan_bound",
    "passes": "sacflow.compare.pass_history",
    "plot": "sacflow.compare.plots",
    "residual_map": "sacflow.compare.fields",
    "summary": "sacflow.compare.output",
    "summary_numbers": "sacflow.compare.output",
    "track": "sacflow.compare.rolling_track",
    "vertical_vs_rolling": "sacflow.compare.pairs",
    "write": "sacflow.compare.output",
}


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
