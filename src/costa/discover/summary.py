"""The discovery cases side by side: what was hidden, what was found, the gap before and after."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

__all__ = ["discovery_summary", "judged", "sensors_summary"]


def discovery_summary(
    findings_paths: Sequence[str | Path], costa_paths: Sequence[str | Path], window: str = "long"
) -> pd.DataFrame:
    """One row per case (``costa_paths`` in the same order as ``findings_paths``)."""
    rows = []
    for path, costa_path in zip(findings_paths, costa_paths, strict=True):
        f = json.loads(Path(path).read_text())
        errors = {(e["model"], e["window"]): e["error"] for e in f["gap"]["errors"]}
        costa = pd.read_parquet(costa_path).set_index("window")["error"]
        named = [r["named"] for r in f["rounds"] if r["named"]]
        rows.append(
            {
                "case": f["case"],
                "hidden": f.get("hidden", ""),
                "expected_equations": " ".join(f.get("expected_equations", [])),
                "flagged_equations": " ".join(f.get("flagged_equations", f.get("flagged_channels", []))),
                "named": " then ".join(n["hypothesis"] for n in named) or "nothing",
                "correct": _correct(f),
                "closed_form": " | ".join(n["closed_form"] for n in named),
                "error_before": errors.get(("starting model", window)),
                "error_after": errors.get(("corrected model", window), errors.get(("starting model", window))),
                "error_costa_reference": float(costa.get(window, float("nan"))),
                "noise_floor": f["gap"]["noise_floor"][window],
                "shrink": f["gap"]["shrink"].get(window, 0.0),
                "shrink_above_noise_floor": f["gap"]["shrink_above_noise_floor"].get(window, 0.0),
                "rounds": len(f["rounds"]),
                "discovery_seconds": f["discovery_seconds"],
            }
        )
    return pd.DataFrame(rows)


def _correct(f) -> bool | None:
    """For a shipped case: the expected equations flagged and an accepted explanation named first."""
    if "accepted" not in f:
        return None
    if not f["accepted"]:
        return not f["named"] and not f["flagged_equations"]
    return (
        set(f["flagged_equations"]) == set(f["expected_equations"])
        and bool(f["named"])
        and f["named"][0] in f["accepted"]
    )


def judged(f) -> str:
    """A run on a simulated case against what is hidden in it (its ``accepted`` names): right, wrong, not
    identifiable (the truth listed among the correction, its equivalents and the hypotheses not fitted,
    or not), unexplained or missed; for a null case,
    quiet, a false alarm (flagged, not named) or a false name."""
    named, accepted = f["named"], f.get("accepted", [])
    flagged = f.get("flagged_equations", f.get("flagged_channels", []))
    if not accepted:
        return "false name" if named else "false alarm" if flagged else "quiet"
    if named:
        return "right" if named[0] in accepted else "wrong"
    if f["outcome"].startswith("not identifiable"):
        listed = {
            c["hypothesis"]
            for r in f["rounds"]
            for c in [r.get("correction") or {}, *r.get("equivalent", []), *r.get("not_fitted", [])]
            if c
        }
        return "not identifiable, truth listed" if listed & set(accepted) else "not identifiable, truth not listed"
    return "unexplained" if flagged else "missed"


def _verdict(f) -> str:
    """What a run on a shipped case concluded, in the words of the sensors table."""
    verdict = judged(f)
    if verdict in ("wrong", "false name"):
        return f"wrongly named ({f['named'][0]})"
    return {
        "right": "named correctly", "not identifiable, truth listed": "not identifiable",
        "not identifiable, truth not listed": "not identifiable", "unexplained": "unexplained", "missed": "not detected",
        "quiet": "no effect, correctly", "false alarm": "unexplained (false alarm)",
    }[verdict]  # fmt: skip


def sensors_summary(findings_paths: Sequence[str | Path], sensors: Sequence[str], window: str = "long") -> pd.DataFrame:
    """One row per shipped case and sensor set (``sensors`` in the order of ``findings_paths``)."""
    rows = []
    for path, sensor_set in zip(findings_paths, sensors, strict=True):
        f = json.loads(Path(path).read_text())
        errors = {(e["model"], e["window"]): e["error"] for e in f["gap"]["errors"]}
        # a partial round's correction is there even when it could not be named
        corrections = [c for r in f["rounds"] if (c := r.get("correction") or r.get("named"))]
        rows.append(
            {
                "case": f["case"].split("/")[0],
                "sensors": sensor_set,
                "measured": " ".join(c["channel"] for c in f.get("channels", []) if c["status"] != "unmeasured"),
                "flagged": " ".join(f.get("flagged_equations", f.get("flagged_channels", []))),
                "verdict": _verdict(f),
                "named": " then ".join(f["named"]) or "—",
                "closed_form": " | ".join(c["closed_form"] for c in corrections),
                "terms": " | ".join(str(len(c["terms"])) for c in corrections),
                "error_before": errors.get(("starting model", window)),
                "error_after": errors.get(("corrected model", window), errors.get(("starting model", window))),
                "noise_floor": f["gap"]["noise_floor"][window],
                "shrink_above_noise_floor": f["gap"]["shrink_above_noise_floor"].get(window, 0.0),
                "discovery_seconds": f["discovery_seconds"],
            }
        )
    return pd.DataFrame(rows)
