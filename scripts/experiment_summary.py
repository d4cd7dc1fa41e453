#!/usr/bin/env python3
"""One table across datasets from `morsegs experiment`'s RESULTS.json: for each variant and
hypothesis, the change against the baseline per dataset (mean over seeds) and the verdicts
counted (after Holm's correction when the report has it). Prints Markdown (the README's verdict table is this script's output).

usage: scripts/experiment_summary.py [--compact] DIR/RESULTS.json
       scripts/experiment_summary.py --compare A/RESULTS.json B/RESULTS.json
  --compact: one row per variant, one cell per hypothesis (verdict counts over the datasets
  and the range of the mean changes), printed before the per-dataset tables.
  --compare: every cell (dataset, variant, hypothesis) that both experiments measured, the
  verdict and mean change of each side by side, and the cells whose verdict differs (e.g.
  the compressed schedule against the full 30,000 iterations: does any verdict change?).
"""
import json
import os
import sys

HYPS = [("H1", "H1 Chamfer", "%"), ("H2", "H2 floaters (seed's count)", "%"),
        ("H2_visible", "H2 visible floater mass", "%"), ("H3", "H3 Gaussians at equal PSNR", "%"),
        ("H4", "H4 PSNR", "dB"), ("H4_ssim", "H4 SSIM", "")]


def word(h):
    """The verdict to quote: after Holm's correction when the report has it (version 2)."""
    return h.get("verdict_holm", h.get("verdict", "n/a"))


def change(h, unit):
    """The mean change as a fraction (%) or in the unit: version 2 reports log-ratios and
    their display value (shown_mean, in %); version 1 a relative change_mean."""
    if "shown_mean" in h:
        m = h.get("shown_mean")
        return None if m is None else (m / 100 if unit == "%" else m)
    return h.get("change_mean")


def fmt(h, unit):
    m = change(h, unit)
    if m is None or word(h) in (None, "n/a"):
        return "n/a"
    if unit == "%":
        return "%+.0f %%" % (100 * m)
    if unit == "dB":
        return "%+.2f" % m
    return "%+.4f" % m


def compact(d, variants):
    """One row per variant, one cell per hypothesis: the verdicts over the datasets and the
    range of the mean changes."""
    print("| variant | " + " | ".join(t for _, t, _ in HYPS) + " |")
    print("|---|" + "---|" * len(HYPS))
    for vn in variants:
        cells = []
        for key, _, unit in HYPS:
            verdicts, changes = [], []
            for ds in d["datasets"]:
                v = next((x for x in ds["variants"] if x["name"] == vn), None)
                h = (v or {}).get("hypotheses", {}).get(key, {})
                verdicts.append(word(h))
                if word(h) not in (None, "n/a") and change(h, unit) is not None:
                    changes.append(change(h, unit))
            parts = ["%d %s" % (verdicts.count(k), k) for k in ("yes", "partly", "worse") if verdicts.count(k)]
            if not parts:
                parts = ["no" if verdicts.count("no") else "n/a"]
            rng = ""
            if changes:
                lo, hi = min(changes), max(changes)
                if unit == "%":
                    rng = " (%+.0f … %+.0f %%)" % (100 * lo, 100 * hi)
                elif unit == "dB":
                    rng = " (%+.2f … %+.2f dB)" % (lo, hi)
                else:
                    rng = " (%+.4f … %+.4f)" % (lo, hi)
            cells.append(", ".join(parts) + rng)
        print("| %s | %s |" % (vn, " | ".join(cells)))
    print()


def cells_of(d):
    """(dataset, variant, hypothesis) -> the hypothesis record, for every measured cell."""
    out = {}
    for ds in d["datasets"]:
        for v in ds["variants"]:
            for key, _, _ in HYPS:
                h = v.get("hypotheses", {}).get(key)
                if h and word(h) not in (None, "n/a"):
                    out[(ds["name"], v["name"], key)] = h
    return out


def compare(path_a, path_b):
    """The cells both experiments measured, side by side; returns the number that differ."""
    with open(path_a) as f:
        a = json.load(f)
    with open(path_b) as f:
        b = json.load(f)
    ca, cb = cells_of(a), cells_of(b)
    common = [k for k in ca if k in cb]
    units = {key: unit for key, _, unit in HYPS}
    print("A: %s (%d iterations, %d of %d runs); B: %s (%d iterations, %d of %d runs); %d cells in both, "
          "%d only in A, %d only in B.\n" % (path_a, a["iterations"], a["runs_finished"], a["runs_planned"], path_b,
                                            b["iterations"], b["runs_finished"], b["runs_planned"], len(common),
                                            len(ca) - len(common), len(cb) - len(common)))
    print("| dataset | variant | hypothesis | A | B | same verdict |")
    print("|---|---|---|---|---|---|")
    differ = 0
    for k in common:
        u = units[k[2]]
        wa, wb = word(ca[k]), word(cb[k])
        differ += wa != wb
        print("| %s | %s | %s | %s (%s) | %s (%s) | %s |" % (k[0], k[1], k[2], fmt(ca[k], u), wa, fmt(cb[k], u), wb,
                                                        "yes" if wa == wb else "**no**"))
    print("\n%d of %d verdicts differ between A and B." % (differ, len(common)))
    return differ


def main():
    if sys.argv[1:2] == ["--compare"]:
        if len(sys.argv) != 4:
            sys.exit(__doc__)
        compare(sys.argv[2], sys.argv[3])
        return
    want_compact = "--compact" in sys.argv[1:]
    args = [a for a in sys.argv[1:] if a != "--compact"]
    if len(args) != 1:
        sys.exit(__doc__)
    sys.argv = [sys.argv[0]] + args  # the run folders are found next to RESULTS.json
    with open(args[0]) as f:
        d = json.load(f)
    names = [ds["name"] for ds in d["datasets"]]
    variants = [v["name"] for v in d["variants"] if v["name"] != "baseline"]
    print("%d of %d runs, %d iterations, %d seeds; datasets: %s.\n" % (
        d["runs_finished"], d["runs_planned"], d["iterations"], d["seeds"], ", ".join(names)))
    if want_compact:
        compact(d, variants)
    for key, title, unit in HYPS:
        print("**%s** — change against the baseline per dataset (%s), mean over seeds; verdicts counted "
              "(yes / partly / no / worse / n/a):\n" % (title, ", ".join(names)))
        print("| variant | " + " | ".join(names) + " | yes | partly | no | worse | n/a |")
        print("|---|" + "---|" * len(names) + "---|---|---|---|---|")
        for vn in variants:
            cells, counts = [], {"yes": 0, "partly": 0, "no": 0, "worse": 0, "n/a": 0}
            for ds in d["datasets"]:
                v = next((x for x in ds["variants"] if x["name"] == vn), None)
                h = (v or {}).get("hypotheses", {}).get(key, {})
                verdict = word(h)
                counts[verdict if verdict in counts else "n/a"] += 1
                cell = fmt(h, unit)
                if verdict in ("yes", "partly", "worse"):
                    cell += " (%s)" % verdict
                cells.append(cell)
            print("| %s | %s | %d | %d | %d | %d | %d |" % (vn, " | ".join(cells), counts["yes"], counts["partly"],
                                                           counts["no"], counts["worse"], counts["n/a"]))
        print()
    # topology of the final α-surface and cost, from the runs
    print("**Topology and cost** — per dataset: seeds whose persistent Betti numbers equal the GT mesh's, "
          "bottleneck distance to the GT diagram (mean), training seconds (mean; the Morse analyses' share of it in brackets):\n")
    print("| variant | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for vn in ["baseline"] + variants:
        cells = []
        for ds in d["datasets"]:
            runs = [r for r in ds.get("runs", []) if r["variant"] == vn and r.get("iteration") == d["iterations"]]
            if not runs:
                cells.append("–")
                continue
            ok = sum(1 for r in runs if r.get("betti_persistent") == ds["gt_betti_persistent"])
            bn = [r["bottleneck"] for r in runs if isinstance(r.get("bottleneck"), (int, float))]
            ts = [r["train_seconds"] for r in runs if isinstance(r.get("train_seconds"), (int, float))]
            an = []
            for r in runs:  # the Morse analyses' share of the training time, from each run's train_stats.json
                ts_path = os.path.join(os.path.dirname(os.path.abspath(sys.argv[1])), "runs", ds["name"], vn,
                                       "seed_%d" % r["seed"], "train_stats.json")
                try:
                    with open(ts_path) as f:
                        st = json.load(f)
                    if st.get("morse_analysis_seconds") and st.get("train_seconds"):
                        an.append(st["morse_analysis_seconds"] / st["train_seconds"])
                except (OSError, ValueError):
                    pass
            cell = "%d/%d, %s, %s s" % (ok, len(runs), ("%.3f" % (sum(bn) / len(bn))) if bn else "inf",
                                       ("%.0f" % (sum(ts) / len(ts))) if ts else "?")
            if an:
                cell += " (%.0f %%)" % (100 * sum(an) / len(an))
            cells.append(cell)
        print("| %s | %s |" % (vn, " | ".join(cells)))
    print()


if __name__ == "__main__":
    main()
