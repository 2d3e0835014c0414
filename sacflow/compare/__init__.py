"""Comparison stages: stored runs (xarray Datasets) -> result Datasets, plots, files.

Each stage is a plain function of one or more runs (opened Datasets or run-file paths) returning
an :class:`xarray.Dataset` whose variables carry ``units`` and ``long_name``; 0-d variables are
its summary numbers, attribute ``stage`` names it. Computation and plotting are separate:
``plots.plot(result)`` draws any result, :func:`write` stores ``stem.nc`` + ``stem.png``,
:func:`summary` prints the numbers. See ``docs/compare.md``.

=========================  ======================================  =========================
stage (CLI name)           function                                seed
=========================  ======================================  =========================
``hertz-check``            :func:`hertz_check`                     Hertz, §3.2 Figs. 7–8
``indentation``            :func:`indentation_profiles`            Figs. 13–16
``load-approach``          :func:`load_approach`                   Fig. 11
``elastic-vs-plastic``     :func:`elastic_vs_plastic`              Fig. 20
``vertical-vs-rolling``    :func:`vertical_vs_rolling`             Fig. 22
``track``                  :func:`track_profile`                   Fig. 18
``residual-map``           :func:`residual_map`                    Fig. 21
``campaign-summary``       :func:`campaign_summary`                campaigns
``case-vs-reference``      :func:`case_vs_reference`               any reference data
=========================  ======================================  =========================

Submodules are imported on first use, so that ``sacflow`` stays quick to start.
"""

from __future__ import annotations

from sacflow.lazy_exports import lazy_exports

__all__ = [
    "CompareError",
    "campaign_summary",
    "case_vs_reference",
    "elastic_vs_plastic",
    "hertz_check",
    "indentation_profiles",
    "load_approach",
    "plot",
    "residual_map",
    "summary",
    "summary_numbers",
    "track_profile",
    "vertical_vs_rolling",
    "write",
]

_EXPORTS = {
    "CompareError": "sacflow.compare.core",
    "campaign_summary": "sacflow.compare.campaign",
    "case_vs_reference": "sacflow.compare.reference",
    "elastic_vs_plastic": "sacflow.compare.pairs",
    "hertz_check": "sacflow.compare.hertz",
    "indentation_profiles": "sacflow.compare.fields",
    "load_approach": "sacflow.compare.hertz",
    "plot": "sacflow.compare.plots",
    "residual_map": "sacflow.compare.fields",
    "summary": "sacflow.compare.output",
    "summary_numbers": "sacflow.compare.output",
    "track_profile": "sacflow.compare.track",
    "vertical_vs_rolling": "sacflow.compare.pairs",
    "write": "sacflow.compare.output",
}


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
