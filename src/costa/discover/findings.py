"""What a discovery run found, as JSON (``findings.json``) and as readable text (``findings.md``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from ..physics import CellModel
from ..variables import MEANING, STATES, UNIT
from .core.fitted_terms import KEEP_LEVEL
from .core.hypotheses import candidate_hypotheses
from .core.naming import fit_outcome, removal
from .core.outcome import Outcome, Round
from .rates import how_often_right, truth_listed, undecided_outcome
from .sparse.innovations import LostCell, describe_lost

#: the levels of the coefficient intervals reported; the last one decides which terms are kept
LEVELS = (0.95, KEEP_LEVEL)

__all__ = ["corrected_model", "findings", "findings_markdown"]


def corrected_model(found: Mapping[str, Any], start: CellModel) -> CellModel:
    """The model a findings.json's rounds end with: ``start`` with each round's applied closed form
    put in (hypothesis, terms, coefficients), named or not identifiable."""
    model = start
    for r in found["rounds"]:
        applied = r["correction"]
        if not applied:
            continue
        hypothesis = next(h for h in candidate_hypotheses(model) if h.key == applied["hypothesis"])
        library = {f.name: f for f in hypothesis.features(rich=True) + hypothesis.features(rich=False)}
        features = [library[c["term"]] for c in applied["coefficients"]]
        model = hypothesis.corrected(model, features, [c["value"] for c in applied["coefficients"]])
    return model


def _candidate(candidate, model) -> dict[str, Any]:
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
        "identifiable": r.identifiable,
        "named": None,
        "correction": None,
        "equivalent": [_candidate(c, r.model) for c in r.equivalent],
        "alternatives": [_candidate(c, r.model) for c in r.ranking if c is not r.chosen and c not in r.equivalent][:5],
    }
    if r.chosen is not None:
        named = _candidate(r.chosen, r.model)
        named["kept_if"] = (
            f"selected in at least half the bootstrap resamples and its {KEEP_LEVEL:.0%} interval "
            f"(from the same resamples; the {LEVELS[0]:.0%} interval lies inside it) excludes zero"
        )
        intervals = {level: r.chosen.intervals(level) for level in LEVELS}
        named["coefficients"] = _coefficients(r.chosen.features, r.chosen.coefficients, intervals, r.chosen.inclusion)
        chosen_terms = {f.name for f in r.chosen.features}
        named["other_terms_inclusion"] = {
            k: v for k, v in sorted(r.chosen.inclusion.items(), key=lambda kv: -kv[1]) if k not in chosen_terms
        }
        named["chi2_after"] = {k: round(v, 3) for k, v in r.chosen.chi2_after.items()}
        found["correction"] = named
        found["named"] = named if r.named is not None else None
    return found


def _coefficients(features, coefficients, intervals_by_level, inclusion) -> list[dict[str, Any]]:
    """One row per kept term: its value, its interval at each reported level, how often selected."""
    return [
        {
            "term": f.name,
            "value": float(c),
            **{f"ci{100 * level:.0f}": list(iv[j]) for level, iv in intervals_by_level.items()},
            "inclusion": None if inclusion is None else inclusion.get(f.name, 0.0),
        }
        for j, (f, c) in enumerate(zip(features, coefficients, strict=True))
    ]


def _sparse_candidate(c, model) -> dict[str, Any]:
    """A partial round's candidate: as on full data, plus the screen's likelihood gain that
    shortlisted it (a correction that could not be scored has no BIC gain), and the trajectories
    whose filter it holds where the uncorrected model's diverged (gains count only the others)."""
    return {
        **_candidate(c, model),
        "bic_gain": round(c.bic_gain, 1) if np.isfinite(c.bic_gain) else None,
        "screen_log_likelihood_gain": round(c.score.log_likelihood_gain, 1),
        "trajectories_held_where_the_model_diverged": c.rescued,
    }


def _recommendations(r: Round, records: str) -> list[dict[str, Any]]:
    """A sparse round's recommended measurements, each with its chance of a name and, where the benchmark's dev
    rounds of ``records`` and of the round's outcome were counted (:func:`.rates.truth_listed`), of a right name."""
    listed = truth_listed(records, undecided_outcome(r.verdict)) if r.measure_next else None
    return [
        {
            "channel": m.channel,
            "meaning": MEANING[m.channel] if m.channel else "the channels this record measures",
            "multiple": m.multiple,
            "every_s": m.every_s,
            "noise": m.noise,
            "separation_noise_stds": round(m.separation, 1),
            "best": m.best,
            "rival": m.rival,
            "name_probability": round(m.decides, 3),
            "explanations": list(m.explanations),
            "right_name_probability": round(m.decides * listed["share"], 3) if listed else None,
            "truth_listed": listed,
        }
        for m in r.measure_next
    ]


def _sparse_round(index: int, r: Round, records: str) -> dict[str, Any]:
    """A round on partial measurements: channel tests instead of equation tests; ``records``: the benchmark's
    sensor set sampled as the data are, whose dev rounds calibrate the chance of a right name."""
    found: dict[str, Any] = {
        "round": index,
        "model": r.model.name,
        "richer_library": r.rich,
        "channels_tested": [
            {
                "channel": t.channel,
                "meaning": MEANING[t.channel],
                "samples": t.samples,
                "chi2_per_dof": round(t.chi2_per_dof, 3),
                "z": round(t.z, 1),
                "bias": round(t.bias, 3),
                "bias_z": round(t.bias_z, 1),
                "whiteness_z": round(t.whiteness_z, 1),
                "flagged": t.flagged,
            }
            for t in r.tests
        ],  # fmt: skip
        "left_out_cell": None if r.left_out is None else dataclasses.asdict(r.left_out),
        "filter_lost": [dataclasses.asdict(c) for c in r.lost],
        "flagged": r.flagged,
        "decided_by": DECIDED_BY[r.route] if r.flagged else None,
        "verdict": r.verdict,
        "identifiable": r.identifiable,
        "unexplained_after_correction": r.unexplained,
        "form_incomplete": r.form_incomplete,
        "at_term_budget": [
            {
                "rival": b.rival,
                "terms": b.terms,
                "chosen_bic_gain": round(b.chosen_gain, 1) if np.isfinite(b.chosen_gain) else None,
                "rival_bic_gain": round(b.rival_gain, 1),
                "matched": b.matched,
            }
            for b in r.at_budget
        ],
        "separated_by": r.separated_by,
        "measure_next": _recommendations(r, records),
        "misfit_after_best": round(r.dispersion, 3),
        "named": None,
        "correction": None,
        "equivalent": [_sparse_candidate(c, r.model) for c in r.equivalent],
        "not_fitted": [{"hypothesis": h.key, "description": h.describe(r.model)} for h in r.not_fitted],
        "alternatives": [
            _sparse_candidate(c, r.model) for c in r.ranking if c is not r.chosen and c not in r.equivalent
        ][:5],
    }
    if r.chosen is not None:
        correction = _sparse_candidate(r.chosen, r.model)
        correction["kept_if"] = KEPT_IF[r.route]
        intervals = {level: r.chosen.intervals(level) for level in LEVELS}
        correction["coefficients"] = _coefficients(
            r.chosen.features, r.chosen.coefficients, intervals, r.chosen.inclusion
        )
        correction["channels_after"] = {t.channel: round(t.chi2_per_dof, 3) for t in r.chosen.tests_after}
        found["correction"] = correction
        if r.named is not None:
            found["named"] = correction
        if r.named is not None and r.named != r.chosen.hypothesis:  # the flow missing from the balance it moves
            h = r.named
            found["named"] = correction | {
                "hypothesis": h.key, "kind": h.kind, "target": h.target, "description": h.describe(r.model),
                "fitted_as": r.chosen.hypothesis.key,
            }  # fmt: skip
    return found


#: how a round on partial measurements was decided (its ``route``: :attr:`.sparse.rounds.SparseRound.route`)
DECIDED_BY = {
    "filter": "each hypothesis' free delta smoothed by the filter on every cell, its closed form regressed on it and "
    "refined on the measured channels, the corrected models compared by the BIC gain of their filter's likelihood",
    "shooting": "multiple shooting on the first cells: every hypothesis' closed form of at most 3 terms screened "
    "linearised at the uncorrected model's fit, the best fitted through the continuity stages to the filter's process "
    "noise, compared by BIC gain (each cell paying its share of the terms) and each channel's noise band",
}
#: the rule a term of the chosen closed form passed, by route
KEPT_IF = {
    "filter": "selected in at least half the bootstrap resamples of the regression on the smoothed delta (or a flow "
    f"input, refined beside them), and its {KEEP_LEVEL:.0%} interval from the fit to the measured channels (the "
    f"refined posterior; the {LEVELS[0]:.0%} interval lies inside it) excludes zero; in the first round a constant "
    "alone, refined on the measured channels, replaces the form where it scores better (2 log-likelihood - terms ln(samples))",
    "shooting": "chosen by forward selection on the screen's normal equations while it lowers the cost by more than "
    "log(samples) (BIC); the intervals are the fit's Gauss-Newton posterior, the states eliminated",
}


GLOSSARY = "docs/glossary.md"


def _undecidable(u: str) -> str:
    """What a record in which input ``u`` did not vary cannot decide."""
    return (
        f"the {MEANING[u]} did not vary, so terms in {u} left the closed forms (they duplicate the constant) and an "
        f"effect that depends on {u} is not identifiable from this record: it reads as a constant at this {u}; "
        f"a record in which the {MEANING[u]} changes would tell"
    )


def _unlogged(u: str, value: float) -> str:
    """What a record whose input ``u`` was not logged (held at ``value`` by the user's word) cannot decide."""
    return (
        f"not logged: held at the declared {value:g} {UNIT[u]}, so terms in {u} left the closed forms and an effect "
        f"that depends on {u} is not identifiable from this record; where the {MEANING[u]} in fact moved, its "
        f"effect on the cell shows as a disagreement the model cannot place; logging {u} would tell"
    )


def findings(
    result: Outcome,
    name: str,
    start,
    meta: Mapping[str, Any],
    channels: pd.DataFrame | None = None,
    constants: pd.DataFrame | None = None,
) -> dict[str, Any]:
    """Everything a run found; ``meta`` describes the data (and, for a shipped case, what is hidden).

    ``channels`` (:func:`costa.data.channel_report`) and ``constants``
    (:func:`costa.physics.constants_table` of the starting model's physics) are
    recorded when given.  A run on partial measurements tests channels, not equations,
    and may find an explanation it cannot name (``identifiable`` False).
    """
    partial = result.measured == "partial"
    rounds = [
        _sparse_round(i + 1, r, result.records) if partial else _round(i + 1, r) for i, r in enumerate(result.rounds)
    ]
    named = [r["named"]["hypothesis"] for r in rounds if r["named"]]
    unidentified = [r for r in rounds if not r["identifiable"] and r["correction"]]
    first = rounds[0]
    if named:
        outcome = "found"
    elif unidentified:
        outcome = "not identifiable"
    elif first["flagged"]:
        outcome = "unexplained"
    else:
        outcome = "no effect"
    extra: dict[str, Any] = {}
    if channels is not None:
        extra["channels"] = channels.astype(object).where(channels.notna(), None).to_dict(orient="records")
    if constants is not None:
        extra["constants"] = constants.to_dict(orient="records")
    unlogged = meta.get("unlogged_inputs") or {}
    extra["inputs_that_did_not_vary"] = [
        {
            "input": u,
            "meaning": MEANING[u],
            "consequence": _unlogged(u, unlogged[u]) if u in unlogged else _undecidable(u),
        }
        for u in result.constant_inputs
    ]
    if partial:
        measured = {"measurements": "partial", "flagged_channels": first["flagged"]}
        noise = dict(zip(result.channels, map(float, result.noise), strict=True))
        definition = (
            "median over held-out rollouts of the coded error on the measured channels (mean |forecast - measured| / "
            f"channel std over the sampled steps), each rollout from the state its model estimates from the first "
            f"{result.start_steps} samples"
        )
        if result.restart_steps:
            definition += (
                f", and again every {result.restart_steps} samples from the state it estimates from the first "
                f"{result.start_steps} samples then (scored after them)"
            )
    else:
        measured = {"measurements": "full", "flagged_equations": first["flagged"]}
        noise = {s: float(v) for s, v in zip(STATES, result.noise, strict=True)}
        definition = "median over held-out rollouts of the coded AN-RFMSE per window"
    return {
        "case": name,
        "glossary": GLOSSARY,
        **dict(meta),
        **extra,
        "starting_model": start.name,
        "outcome": outcome,
        "how_often_right": how_often_right(result.records),
        **measured,
        "named": named,
        "noise_estimate": noise,
        "rounds": rounds,
        "corrected_model": result.corrected.describe(),
        "gap": {
            "definition": definition,
            "windows": {w: list(map(int, bounds)) for w, bounds in result.windows.items()},
            "dt_s": result.dt,
            "errors": result.gap.to_dict(orient="records"),
            "noise_floor": result.floor,
            **_shrink(result.gap, result.floor),
        },
        "discovery_seconds": round(result.seconds, 1),
    }


def _shrink(gap: pd.DataFrame, floor: Mapping[str, float]) -> dict[str, dict[str, float]]:
    """Per window: the share of the starting model's error the correction removes, raw and above the floor."""
    errors = gap.pivot(index="model", columns="window", values="error")
    shrink, above_floor = {}, {}
    if "corrected model" in errors.index:
        for w in errors.columns:
            before, after = errors.loc["starting model", w], errors.loc["corrected model", w]
            shrink[w] = float(1 - after / before) if before > 0 else 0.0
            above_floor[w] = float(min(1.0, (before - after) / (before - floor[w]))) if before > floor[w] else 0.0
    return {"shrink": shrink, "shrink_above_noise_floor": above_floor}


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
    if f.get("how_often_right"):
        lines += ["**How often a name is right** (the discovery benchmark, docs/discovery.md):", ""]
        lines += [f"- {sentence}" for sentence in f["how_often_right"]]
        lines.append("")
    if f.get("inputs_that_did_not_vary"):
        lines += ["**Inputs that did not vary** (what this record cannot decide):", ""]
        lines += [f"- {i['input']} ({i['meaning']}): {i['consequence']}" for i in f["inputs_that_did_not_vary"]]
        lines.append("")
    if f.get("channels"):
        lines += ["**Measured channels**:", ""]
        lines += [f"- {line}" for line in _channel_lines(f["channels"])]
        lines.append("")
    for r in f["rounds"]:
        lines += _sparse_round_lines(r) if "channels_tested" in r else _round_lines(r)
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


def _round_lines(r: Mapping[str, Any]) -> list[str]:
    """A full-data round: the equations' tests, the verdict, the named correction and the others."""
    lines = [f"## Round {r['round']}" + (" (richer term library)" if r["richer_library"] else ""), ""]
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
            f"- {state}'s residual follows " + ", ".join(f"{i['variable']} (rho {i['spearman']:+.2f})" for i in items)
        )
    if r["correction"]:
        n = r["correction"]
        title = "Named" if r["named"] else "Best-fitting correction (applied, not named: not identifiable)"
        lines += [
            "",
            f"**{title}**: `{n['hypothesis']}`: {n['description']}",
            "",
            f"Correction [{n['unit']}]: `{n['closed_form']}`",
            "",
        ]
        lines += _coefficient_lines(n)
    if r["equivalent"]:
        lines += ["", "Equivalent under these measurements (the data cannot tell them apart):"]
        lines += [f"- `{c['hypothesis']}`: `{c['closed_form']}`" for c in r["equivalent"]]
    if r["alternatives"]:
        lines += ["", "Runners-up:"]
        lines += [
            f"- `{c['hypothesis']}` {removal(c['excess_removed'])} (BIC gain {c['bic_gain']:.0f})"
            for c in r["alternatives"]
        ]
    lines.append("")
    return lines


def _coefficient_lines(n: Mapping[str, Any]) -> list[str]:
    levels = [key for key in n["coefficients"][0] if key.startswith("ci")] if n["coefficients"] else []
    lines = [
        "| term | coefficient | "
        + " | ".join(f"{level[2:]} % interval" for level in levels)
        + " | selected in resamples |"
    ]
    lines.append("|---|---|" + "---|" * len(levels) + "---|")
    lines += [
        f"| `{c['term']}` | {c['value']:.4g} | "
        + " | ".join(f"[{c[level][0]:.4g}, {c[level][1]:.4g}]" for level in levels)
        + (" | — |" if c["inclusion"] is None else f" | {c['inclusion']:.0%} |")
        for c in n["coefficients"]
    ]
    return lines + ["", f"A term is kept if {n['kept_if']}."]


def _sparse_round_lines(r: Mapping[str, Any]) -> list[str]:
    """A round on partial measurements: the channels' innovation tests, the verdict, the correction
    (named only when the measurements can tell it from the other explanations)."""
    lines = [
        f"## Round {r['round']}" + (" (richer term library)" if r["richer_library"] else ""),
        "",
        "Innovations of the smoother on each measured channel (white, zero-mean and of unit variance under a right model).",
        "",
    ]
    if r.get("left_out_cell"):
        lines += [f"Cell {r['left_out_cell']['cell']} left out: it alone disagreed (the verdict says where).", ""]
    if r.get("filter_lost"):
        lost = describe_lost([LostCell(**c) for c in r["filter_lost"]])
        lines += [
            f"The filter of the model tested was lost on {lost}: it could not follow them from there, and their "
            "samples from there are in no test or likelihood (the scores use the cells it holds).",
            "",
        ]
    lines.append("| channel | meaning | samples | chi2/dof | z | bias | bias z | whiteness z | disagrees |")
    lines.append("|---|---|---|---|---|---|---|---|---|")
    lines += [
        f"| {t['channel']} | {t['meaning']} | {t['samples']} | {t['chi2_per_dof']} | {t['z']} | {t['bias']} | "
        f"{t['bias_z']} | {t['whiteness_z']} | {'yes' if t['flagged'] else ''} |"
        for t in r["channels_tested"]
    ]
    lines += ["", f"**Verdict**: {r['verdict']}.", ""]
    if r.get("decided_by"):
        lines += [f"Decided by {r['decided_by']}.", ""]
    correction = r.get("correction")
    if correction:
        reason = "not identifiable" if not r["identifiable"] else "unexplained"
        title = "Named" if r["named"] else f"Best-fitting correction (applied, not named: {reason})"
        title += " (form incomplete)" if r.get("form_incomplete") else ""
        shown = r["named"] or correction
        fitted = f" (fitted as `{shown['fitted_as']}`)" if shown.get("fitted_as") else ""
        lines += [f"**{title}**: `{shown['hypothesis']}`{fitted}: {shown['description']}", "",
                  f"Correction [{correction['unit']}]: `{correction['closed_form']}`", ""]  # fmt: skip
        lines += _coefficient_lines(correction)
    if r["equivalent"]:
        lines += ["", "Equivalent under these measurements (the data do not tell them from it; the verdict says why):"]
        lines += [
            f"- `{e['hypothesis']}`: `{e['closed_form']}`"
            + ("" if e["bic_gain"] is None else f" (BIC gain {e['bic_gain']:.0f})")
            for e in r["equivalent"]
        ]
    if r.get("not_fitted"):
        lines += ["", "Not excluded by the screen and not fitted (no name stands while they stand):"]
        lines += [f"- `{h['hypothesis']}`: {h['description']}" for h in r["not_fitted"]]

    lines += _measure_next_lines(r)
    if r.get("at_term_budget"):
        lines += ["", "Against rivals with fewer terms, the correction cut to as many terms (named only if it still "
                  "leads by the equivalence margin):"]  # fmt: skip
        lines += [
            f"- `{b['rival']}` ({b['terms']} terms, BIC gain {b['rival_bic_gain']:.0f}): cut, "
            + ("lost on a cell" if b["chosen_bic_gain"] is None else f"{b['chosen_bic_gain']:.0f}")
            + (", matched: undecided" if b["matched"] else ", still ahead")
            for b in r["at_term_budget"]
        ]
    if r.get("misfit_after_best", 1.0) > 1.0:
        lines += ["", f"The best correction still leaves a mean square innovation of {r['misfit_after_best']:.3g} "
                  f"(1 under a right model): BIC differences count {r['misfit_after_best']:.3g} times less as evidence."]  # fmt: skip
    if r["alternatives"]:
        lines += ["", "Runners-up:"]
        lines += [
            f"- `{a['hypothesis']}` {fit_outcome(bool(a['terms']), a['excess_removed'], a['bic_gain'] is not None)}"
            + ("" if a["bic_gain"] is None else f" (BIC gain {a['bic_gain']:.0f})")
            for a in r["alternatives"]
        ]
    return lines + [""]


def _measure_next_lines(r: Mapping[str, Any]) -> list[str]:
    """A sparse round's recommended measurements in words (nothing where it decided, or tested nothing)."""
    if r.get("measure_next"):
        lines = ["", "What to measure next, by the chance the added record names an explanation (and the expected "
                  "separation of the best from its nearest rival over this record's cells and hours, in noise stds):"]  # fmt: skip
        listed = r["measure_next"][0]["truth_listed"]
        if listed:
            lines += [f"(A name's chance holds where one of {', '.join(r['measure_next'][0]['explanations'])} is the "
                      f"truth: on the benchmark's {listed['sensors']} records of its {listed['split']} seeds it was in "
                      f"{listed['listed']} of {listed['rounds']} {listed['outcome']} rounds that recommended a "
                      f"measurement ({listed['share']:.0%}, 95 % interval {listed['share_low']:.0%}-"
                      f"{listed['share_high']:.0%}); a right name's chance is the product.)"]  # fmt: skip
        else:
            lines += ["(A name's chance holds only where one of these explanations is the truth; the benchmark "
                      "published no such rounds of records like these to say how often it is.)"]  # fmt: skip
        lines += [
            (
                f"- a record {m['multiple']} times this one (more cells or hours of {m['meaning']}; no instrument a pot "
                "line can add samples a channel more often)"
                if m["channel"] is None
                else f"- `{m['channel']}` ({m['meaning']}) every {m['every_s']:g} s, noise {m['noise']:g}"
            )
            + f": a name with probability {m['name_probability']:.2f}"
            + (f", a right name {m['right_name_probability']:.2f}" if listed else "")
            + f"; {m['separation_noise_stds']:g} from `{m['rival']}`"
            for m in r["measure_next"]
        ]
        return lines
    if r.get("measure_next") == [] and r["flagged"] and not r["named"]:
        return ["", "What to measure next: nothing to recommend; fewer than two explanations were fitted, or the "
                    "channels this record measures, all as often as a pot line can, already separate them (what "
                    "keeps the round undecided is in its verdict)."]  # fmt: skip
    return []
