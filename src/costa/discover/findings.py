"""What a discovery run found, as JSON (``findings.json``) and as readable text (``findings.md``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pandas as pd

from ..variables import MEANING, STATES
from .pipeline import DiscoveryResult
from .search import KEEP_LEVEL, Candidate, Round

#: the levels of the coefficient intervals reported; the last one decides which terms are kept
LEVELS = (0.95, KEEP_LEVEL)

__all__ = ["findings", "findings_markdown"]


def _candidate(candidate: Candidate, model) -> dict[str, Any]:
    h = candidate.hypothesis
    return {
        "hypothesis": h.key,
        "kind": h.kind,
        "target": h.target,
        "unit": h.unit,
        "description": h.describe(model),
        "closed_form": candidate.formula,
        "terms": [f.name for f in candidate.features],
        "excess_removed": round(candidate.explained, 4),
        "bic_gain": round(candidate.bic_gain, 1),
    }


def _round(index: int, r: Round) -> dict[str, Any]:
    found: dict[str, Any] = {
        "round": index,
        "model": r.model.name,
        "richer_library": r.rich,
        "window_steps": r.window,
        "equations": [
            {
                "state": t.state,
                "meaning": MEANING[t.state],
                "chi2_per_dof": round(t.chi2_per_dof, 3),
                "z": round(t.z, 1),
                "flagged": t.flagged,
            }
            for t in r.tests
        ],  # fmt: skip
        "flagged": r.flagged,
        "where": {
            state: [{"variable": v, "spearman": round(c, 3)} for v, c in items] for state, items in r.where.items()
        },
        "verdict": r.verdict,
        "named": None,
        "equivalent": [_candidate(c, r.model) for c in r.equivalent],
        "alternatives": [_candidate(c, r.model) for c in r.ranking if c is not r.chosen and c not in r.equivalent][:5],
    }
    if r.chosen is not None:
        named = _candidate(r.chosen, r.model)
        named["kept_if"] = (
            f"selected in at least half the bootstrap resamples and its {KEEP_LEVEL:.0%} interval "
            f"(from the same resamples; the {LEVELS[0]:.0%} interval lies inside it) excludes zero"
        )
        intervals = [r.chosen.intervals(level) for level in LEVELS]
        named["coefficients"] = [
            {
                "term": f.name,
                "value": float(c),
                **{f"ci{100 * level:.0f}": list(iv[j]) for level, iv in zip(LEVELS, intervals, strict=True)},
                "inclusion": r.chosen.inclusion.get(f.name, 0.0),
            }
            for j, (f, c) in enumerate(zip(r.chosen.features, r.chosen.coefficients, strict=True))
        ]
        chosen_terms = {f.name for f in r.chosen.features}
        named["other_terms_inclusion"] = {
            k: v for k, v in sorted(r.chosen.inclusion.items(), key=lambda kv: -kv[1]) if k not in chosen_terms
        }
        named["chi2_after"] = {k: round(v, 3) for k, v in r.chosen.chi2_after.items()}
        found["named"] = named
    return found


GLOSSARY = "docs/glossary.md"


def findings(
    result: DiscoveryResult,
    name: str,
    start,
    meta: Mapping[str, Any],
    channels: pd.DataFrame | None = None,
    constants: pd.DataFrame | None = None,
) -> dict[str, Any]:
    """Everything a run found; ``meta`` describes the data (and, for a shipped case, what is hidden).

    ``channels`` (:func:`costa.data.channel_report`) and ``constants``
    (:func:`costa.physics.constants_table` of the starting model's physics) are
    recorded when given.
    """
    rounds = [_round(i + 1, r) for i, r in enumerate(result.rounds)]
    named = [r["named"]["hypothesis"] for r in rounds if r["named"]]
    first = rounds[0]
    if named:
        outcome = "found"
    elif first["flagged"]:
        outcome = "disagreement without an explanation"
    else:
        outcome = "no effect"
    gap = result.gap.pivot(index="model", columns="window", values="error")
    windows = list(gap.columns)
    shrink, above_floor = {}, {}
    if "corrected model" in gap.index:
        for w in windows:
            before, after, floor = gap.loc["starting model", w], gap.loc["corrected model", w], result.floor[w]
            shrink[w] = float(1 - after / before) if before > 0 else 0.0
            above_floor[w] = float(min(1.0, (before - after) / (before - floor))) if before > floor else 0.0
    extra: dict[str, Any] = {}
    if channels is not None:
        extra["channels"] = channels.astype(object).where(channels.notna(), None).to_dict(orient="records")
    if constants is not None:
        extra["constants"] = constants.to_dict(orient="records")
    return {
        "case": name,
        "glossary": GLOSSARY,
        **dict(meta),
        **extra,
        "starting_model": start.name,
        "outcome": outcome,
        "flagged_equations": first["flagged"],
        "named": named,
        "noise_estimate": {s: float(v) for s, v in zip(STATES, result.noise, strict=True)},
        "rounds": rounds,
        "corrected_model": result.corrected.describe(),
        "gap": {
            "definition": "median over held-out rollouts of the coded AN-RFMSE per window",
            "windows": {w: list(map(int, bounds)) for w, bounds in result.windows.items()},
            "dt_s": result.dt,
            "errors": result.gap.to_dict(orient="records"),
            "noise_floor": result.floor,
            "shrink": shrink,
            "shrink_above_noise_floor": above_floor,
        },
        "discovery_seconds": round(result.seconds, 1),
    }


def findings_markdown(f: Mapping[str, Any]) -> str:
    """The findings as a short readable document."""
    lines = [
        f"# Discovery: {f['case']}",
        "",
        f"Every symbol and term below (x1..x8, c2, g1, k0..k18, chi2/dof, z, BIC gain, inclusion, noise floor, "
        f"AN-RFMSE ...) is explained in `{f.get('glossary', GLOSSARY)}` of the repository; `docs/own-data.md` "
        "shows how to read this page.",
        "",
    ]
    if f.get("hidden"):
        lines += [f"**Hidden in the data** (not told to the workflow): {f['hidden']} ({f['kind']}).", ""]
    lines += [
        f"**Data**: {f['data']}. **Starting model**: `{f['starting_model']}`.",
        "",
        f"**Outcome**: {f['outcome']}.",
        "",
    ]
    if f.get("channels"):
        lines += ["**Measured channels**:", ""]
        lines += [f"- {line}" for line in _channel_lines(f["channels"])]
        lines.append("")
    for r in f["rounds"]:
        lines += [f"## Round {r['round']}" + (" (richer term library)" if r["richer_library"] else ""), ""]
        lines += [f"Residuals averaged over windows of {r['window_steps']} steps.", ""]
        lines.append("| state | meaning | chi2/dof | z | disagrees |")
        lines.append("|---|---|---|---|---|")
        lines += [
            f"| {e['state']} | {e['meaning']} | {e['chi2_per_dof']} | {e['z']} | {'yes' if e['flagged'] else ''} |"
            for e in r["equations"]
        ]
        lines += ["", f"**Verdict**: {r['verdict']}.", ""]
        for state, items in r["where"].items():
            lines.append(
                f"- {state}'s residual follows "
                + ", ".join(f"{i['variable']} (rho {i['spearman']:+.2f})" for i in items)
            )
        if r["named"]:
            n = r["named"]
            lines += [
                "",
                f"**Named**: `{n['hypothesis']}`: {n['description']}",
                "",
                f"Correction [{n['unit']}]: `{n['closed_form']}`",
                "",
            ]
            lines.append("| term | coefficient | 95 % interval | 99 % interval | selected in resamples |")
            lines.append("|---|---|---|---|---|")
            lines += [
                f"| `{c['term']}` | {c['value']:.4g} | [{c['ci95'][0]:.4g}, {c['ci95'][1]:.4g}] | "
                f"[{c['ci99'][0]:.4g}, {c['ci99'][1]:.4g}] | {c['inclusion']:.0%} |"
                for c in n["coefficients"]
            ]
            lines += ["", f"A term is kept if {n['kept_if']}."]
        if r["equivalent"]:
            lines += ["", "Equivalent under these measurements (the data cannot tell them apart):"]
            lines += [f"- `{c['hypothesis']}`: `{c['closed_form']}`" for c in r["equivalent"]]
        if r["alternatives"]:
            lines += ["", "Runners-up:"]
            lines += [
                f"- `{c['hypothesis']}` removes {c['excess_removed']:.0%} of the excess (BIC gain {c['bic_gain']:.0f})"
                for c in r["alternatives"]
            ]
        lines.append("")
    g = f["gap"]
    lines += [
        "## Gap on held-out trajectories",
        "",
        f"{g['definition']}; noise floor = the error a perfect model would still show.",
        "",
    ]
    errors: dict[str, dict[str, float]] = {}
    for row in g["errors"]:
        errors.setdefault(row["model"], {})[row["window"]] = row["error"]
    windows = list(g["noise_floor"])
    if "windows" in g:
        dt = g["dt_s"]
        lines += [
            "Windows in steps of the held-out trajectories (dt = "
            + f"{dt:g} s): "
            + ", ".join(f"{w} [{a}, {b}) = {a * dt:g}-{b * dt:g} s" for w, (a, b) in g["windows"].items()),
            "",
        ]
    lines.append("| model | " + " | ".join(windows) + " |")
    lines.append("|---|" + "---|" * len(windows))
    lines += [f"| {m} | " + " | ".join(f"{e[w]:.4f}" for w in windows) + " |" for m, e in errors.items()]
    lines.append("| noise floor | " + " | ".join(f"{g['noise_floor'][w]:.4f}" for w in windows) + " |")
    if g["shrink"]:
        lines += [
            "",
            "Gap shrink: "
            + ", ".join(
                f"{w} {g['shrink'][w]:.0%} (above the noise floor {g['shrink_above_noise_floor'][w]:.0%})"
                for w in windows
            ),
        ]
    lines += [
        "",
        "## Corrected model",
        "",
        "```",
        f["corrected_model"],
        "```",
        "",
        f"Discovery took {f['discovery_seconds']} s.",
    ]
    if f.get("constants"):
        lines += ["", "<details><summary>The cell's constants (the starting model's)</summary>", ""]
        lines += ["| constant | value | unit | from |", "|---|---|---|---|"]
        lines += [f"| {c['constant']} | {c['value']:.6g} | {c['unit']} | {c['source']} |" for c in f["constants"]]
        lines += ["", "</details>"]
    return "\n".join(lines) + "\n"


def _channel_lines(channels: list[Mapping[str, Any]]) -> list[str]:
    from ..data import format_channel_report

    table = pd.DataFrame(channels).astype({"interval_s": float, "first_s": float, "last_s": float})
    return format_channel_report(table).splitlines()
