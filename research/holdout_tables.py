"""Leave-one-out tables from saved hold-out checkpoints, scored again on their held-out rows.

    python -m research.holdout_tables MODELS_DIR [--dataset datasets/corpus] [--out FILE.md]
                                     [--mirror]

Every ``holdout-NAME.pt`` (an assembly held out) and ``holdout-family-F.pt`` (a family held out)
in MODELS_DIR is scored with ``rap-farm score`` semantics (``rap.model.evaluation.cross_validation.score_checkpoint``)
on the rows it did not see: accuracy, per-class accuracy, ECE and the noise ceiling (the agreement
a perfect predictor of the true success rate would have with these 100-trial labels). Prints and
writes two Markdown tables with their means (the ECE of the mean row is the mean of the folds').
``--mirror``: the network's outputs averaged over each pair and its mirror image (as
``rap-farm score --mirror``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", type=Path)
    ap.add_argument("--dataset", default=str(ROOT / "datasets" / "corpus"))
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--mirror", action="store_true", help="mirror test-time averaging")
    a = ap.parse_args()
    from rap.model.evaluation.cross_validation import score_checkpoint

    pct = lambda x: "–" if x != x else f"{100 * x:.1f}"  # noqa: E731
    text = []
    for kind, prefix in (("assembly", "holdout-"), ("family", "holdout-family-")):
        paths = sorted(p for p in a.models.glob(f"{prefix}*.pt")
                       if kind == "family" or not p.name.startswith("holdout-family-"))
        if not paths:
            continue
        lines = [f"| held-out {kind} | rows | accuracy | low robustness | high robustness | ECE | "
                 f"noise ceiling |", "|---|---:|---:|---:|---:|---:|---:|"]
        rows = []
        for p in paths:
            name = p.stem[len(prefix):]
            r = [x for x in score_checkpoint(p, a.dataset, by=kind, only=[name], mirror=a.mirror)
                 if x[kind] == name][0]
            rows.append(r)
            lines.append(f"| {name} | {r['rows']} | {pct(r['accuracy'])} | {pct(r['low_accuracy'])} | "
                         f"{pct(r['high_accuracy'])} | {pct(r['ece'])} | {pct(r['ceiling'])} |")
            print(lines[-1], flush=True)
        mean = lambda k: sum(r[k] for r in rows) / len(rows)  # noqa: E731
        worst = min(rows, key=lambda r: r["accuracy"])
        lines.append(f"| **mean of {len(rows)}** (worst: {worst[kind]} {pct(worst['accuracy'])}) | "
                     f"{sum(r['rows'] for r in rows)} | **{pct(mean('accuracy'))}** | "
                     f"{pct(mean('low_accuracy'))} | {pct(mean('high_accuracy'))} | {pct(mean('ece'))} | "
                     f"{pct(mean('ceiling'))} |")
        text += [f"Leave-one-{kind}-out ({a.models}{', mirror-averaged' if a.mirror else ''}):", "",
                 *lines, ""]
    out = "\n".join(text)
    print(out)
    if a.out:
        a.out.write_text(out)


if __name__ == "__main__":
    main()
