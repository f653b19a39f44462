"""One experiment summarised, and the comparison across stimulation sites (one row per experiment)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import pandas as pd

from tendrilkit.schema import SITE_COMPARISON
from tendrilkit.sequence.change import TipPathStats, region_response, shape_change, tip_path_stats, tip_trajectory
from tendrilkit.sequence.timing import ResponseTimes, response_times


@dataclass(frozen=True, eq=False)


class ExperimentSummary:
    """Everything the cross-site comparison needs from one experiment.

    Attributes
    ----------
    name : str
    site : str
        ``S1`` .. ``S4`` or "" when unknown.
    response : ResponseTimes
    regions : DataFrame
        :func:`region_response`.
    tip : TipPathStats
    change : DataFrame
        :func:`shape_change`.
    n_frames_ok : int
    failed_frames : tuple of int
    """

    name: str
    site: str
    response: ResponseTimes
    regions: pd.DataFrame
    tip: TipPathStats
    change: pd.DataFrame
    n_frames_ok: int
    failed_frames: tuple = ()


def summarize_experiment(curves: pd.DataFrame, *, name: str = "", site: str = "",
                         segments: pd.DataFrame | None = None, frames: pd.DataFrame | None = None,
                         include_doubtful: bool = False,
                         response_kwargs: Mapping | None = None, tip_median_frames: int = 1) -> ExperimentSummary:
    """Shape change, response times, region response and tip path of one experiment."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        change = shape_change(curves, frames=frames, include_doubtful=include_doubtful)
        resp = response_times(change, **dict(response_kwargs or {}))
        regions = region_response(curves, segments=segments, frames=frames, include_doubtful=include_doubtful)
        tip = tip_path_stats(tip_trajectory(curves, frames=frames, include_doubtful=include_doubtful), median_frames=tip_median_frames)
    seen = set()
    for w in caught:  # report each distinct warning once
        if str(w.message) not in seen:
            seen.add(str(w.message))
            warnings.warn(f"{name or 'experiment'}: {w.message}", w.category, stacklevel=2)
    failed = tuple(change.attrs.get("excluded_frames", ()))
    return ExperimentSummary(name=name, site=site, response=resp, regions=regions, tip=tip,
                             change=change, n_frames_ok=len(change), failed_frames=failed)


def compare_sites(results: Mapping[str, ExperimentSummary | Mapping]) -> pd.DataFrame:
    """The cross-site comparison table, one row per experiment.

    Parameters
    ----------
    results : mapping name -> ExperimentSummary
        (or a mapping with the keys of :data:`tendrilkit.schema.SITE_COMPARISON`,
        taken as is).

    Returns
    -------
    DataFrame
        Columns :data:`tendrilkit.schema.SITE_COMPARISON`, sorted by site then experiment.
        ``tip_displacement_mm`` is the final shape change at the tip.
    """
    rows = []
    for name, r in results.items():
        if isinstance(r, ExperimentSummary):
            reg = r.regions
            if len(reg) and reg["deformation_mm"].notna().any():
                best = reg.loc[reg["deformation_mm"].idxmax()]
                most, dmax = str(best["region"]), float(best["deformation_mm"])
            else:
                most, dmax = "", np.nan
            tipd = float(r.change["tip_displacement_mm"].iloc[-1]) if len(r.change) else np.nan
            rows.append({
                "experiment": str(name), "site": r.site or "", "responded": bool(r.response.responded),
                "onset_s": r.response.onset_s, "stable_s": r.response.stable_s,
                "amplitude_mm": r.response.amplitude_mm, "tip_displacement_mm": tipd,
                "most_responsive_region": most, "max_deformation_mm": dmax,
                "tip_path_mm": r.tip.path_length_mm, "tip_straightness": r.tip.straightness,
                "n_frames_ok": int(r.n_frames_ok), "n_frames_excluded": len(r.failed_frames),
            })
        elif isinstance(r, Mapping):
            row = {c: r.get(c, np.nan) for c in SITE_COMPARISON.columns}
            row["experiment"] = str(r.get("experiment", name))
            rows.append(row)
        else:
            raise TypeError(f"results[{name!r}] must be an ExperimentSummary or a mapping, got {type(r).__name__}")
    out = pd.DataFrame(rows, columns=list(SITE_COMPARISON.columns))
    return out.sort_values(["site", "experiment"], kind="stable").reset_index(drop=True)
