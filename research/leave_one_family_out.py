"""Leave-one-family-out evaluation of the default scorer (issue 45), and the guard's statistics.

    python -m research.leave_one_family_out scorer [--rows 2000] [--rounds 400] [--families a,b] [--train-rows N]
    python -m research.leave_one_family_out plans [--families arch,dovetail] [--seeds 0] [--max-parts 8]
    python -m research.leave_one_family_out guard-stats [--out rap/data/default_model.scorer.guard.json]
    python -m research.leave_one_family_out cnn --checkpoints DIR [--rows 2000]

``scorer``: for every family F of ``datasets/corpus`` (the reference six excepted), the cascade's
trees are retrained on every other family's rows (``research.descriptor_scorer``'s recipe:
LightGBM, cross-entropy on the success rates, ``--rounds`` rounds, seeded, the shipped
temperature) and scored on a seeded sample of ``--rows`` of F's rows; beside them the shipped
CNN on the same rows (rendered images from the corpus: the CNN *has* seen F, so its figures are
optimistic) and the shipped trees (which have seen F too). Per family: accuracy of the P(high)
decision at 0.95, ECE, and the mean absolute error of the expected score.

``cnn``: per family F, a CNN trained without it (``DIR/F.pt``: ``rap-farm train datasets/corpus
--holdout-family F``, at whatever budget the folder's models share) on the rows ``scorer`` measures,
beside ``DIR/all.pt`` (the same recipe and budget on every family, if present): the drop that
leaving F out costs the CNN, to set beside the trees'.

``plans``: small assemblies (at most ``--max-parts`` parts) of the held-out shape kinds
(``rap.geometry.families.unseen``) or of named training families: the default plan (with its
guard), the same cascade without the guard (the trees alone, as before issue 45), the CNN-alone
search and the optimum (``--method optimal``), R and seconds each, one shared root seed; each
one's share of the optimum and whether the guard flagged the assembly. On a flagged assembly also
the search with a gap kept there (``guard_gap``: ``research.variants.guard_gap``, measured not to
pay; its own empty score cache, so its time compares with the default's). Simulations dominate: minutes an assembly on 2 cores.

``guard-stats``: fits ``rap.model.inference.descriptor_model.Familiarity`` (a seeded reference of
60,000 corpus rows; the 0.9 quantile of the other rows' mean distance to their 5 nearest) and
writes the guard file beside the shipped descriptor model (``--share``: the share of an
assembly's sampled operations beyond the limit that flags it; chosen by ``--measure``, which
prints the share of fresh seeds of the training families, of the held-out kinds, and of grids and
tilings of 12-100 parts, beyond the corpus' sizes). The statistic leaves size out (the part counts
and the area fraction: ``rap.model.inference.descriptor_model.size_free``).

Cost: ``scorer`` a LightGBM fit a family (a minute or two each on 2 cores) plus the CNN on
``--rows`` rows; ``plans`` the optimum's simulations; ``guard-stats`` the corpus descriptors
(cached under ``$RAP_CACHE_DIR``) and a 5,000 x 60,000 distance matrix (seconds).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CHECKPOINT = ROOT / "rap" / "data" / "default_model.pt"


def _metrics(labels, prob, expected, scores) -> dict:
    from rap.model.evaluation.metrics import classification_metrics

    m = classification_metrics(labels, prob, reliability=True)
    return {"accuracy": round(float(m["accuracy"]), 4), "ece": round(float(m["ece"]), 4),
            "mae": round(float(np.abs(expected - scores).mean()), 4)}


def scorer_table(rows: int, rounds: int, families: list[str] | None = None,
                 seed: int = 0, train_rows: int = 0) -> list[dict]:
    """The ``scorer`` table (module doc). ``train_rows`` > 0: the trees are fitted on a seeded
    sample of that many rows (left out: of the other families; ``trees_all``: of every family,
    the same budget), to set beside CNNs trained at a small budget (``cnn``)."""
    import lightgbm

    import research.descriptor_scorer as ds
    from rap.model.inference.descriptor_model import DescriptorModel
    from rap.model.inference.operations import OperationPredictor

    store, x = ds.corpus_rows()
    shipped = DescriptorModel.load(ROOT / "rap" / "data" / "default_model.scorer.npz")
    cnn = OperationPredictor.load(CHECKPOINT, engine="cnn")
    sampler = np.random.default_rng(seed + 1)

    def sample(tr):
        """``tr``, or its seeded sample of ``train_rows`` (drawn for every family in turn, run or
        not, so a run of some families fits on the rows a full run does)."""
        if not train_rows:
            return tr
        return np.sort(sampler.choice(tr, min(train_rows, len(tr)), replace=False))

    def fit(tr) -> DescriptorModel:
        data = lightgbm.Dataset(x[tr].astype(np.float64),
                                label=store.successes[tr] / store.trials[tr],
                                weight=store.trials[tr] / 100.0)
        booster = lightgbm.train({**ds.GBT_PARAMS, "seed": seed, "verbose": -1}, data, rounds)
        return DescriptorModel(None, None, [], {**shipped.meta}, booster=booster.model_to_string())

    compared = [("trees_shipped", shipped)]
    if train_rows:
        compared.append(("trees_all", fit(sample(np.arange(len(store.family))))))
    out = []
    for fam, pick in _picks(store, rows, seed).items():
        t = time.perf_counter()
        train = sample(np.flatnonzero(store.family != fam))
        if families and fam not in families:  # drawn anyway: the same rows as a full run's
            continue
        lofo = fit(train)
        labels = store.scores[pick] >= 0.95
        row = {"family": fam, "rows": int(len(pick)), **({"train_rows": train_rows} if train_rows
                                                          else {})}
        for name, model in (("trees_lofo", lofo), *compared):
            p, e = model.prob_high_and_expected(x[pick])
            row[name] = _metrics(labels, p, e, store.scores[pick])
        row["cnn_shipped"] = _cnn_metrics(cnn, store, x, pick)
        row["seconds"] = round(time.perf_counter() - t, 1)
        print(json.dumps(row), flush=True)
        out.append(row)
    return out


def _outcome(result, started: float) -> dict:
    """A plan's row entry: R, seconds since ``started``, and the search's stop, simulations and
    bound gap where it reports them."""
    row = {"R": round(float(result.robustness), 4),
           "seconds": round(time.perf_counter() - started, 1)}
    row.update({k: result.stats[k] for k in ("stopped", "search_simulations") if k in result.stats})
    if result.bound:
        row["bound_gap"] = round(float(result.bound["gap"]), 3)
    return row


def _cnn_metrics(cnn, store, x, pick) -> dict:
    """A loaded CNN's metrics on the corpus rows ``pick`` (the 'pair' view, with the descriptors
    its network takes, if any)."""
    from rap.model.data.descriptors import columns

    cols = getattr(cnn.predictor, "descriptors", ()) or ()
    d = np.ascontiguousarray(x[pick][:, columns(tuple(cols))]) if cols else None
    p, e = cnn.forward("prob_high_and_expected", store.images[pick], d)
    return _metrics(store.scores[pick] >= 0.95, p, e, store.scores[pick])


def _picks(store, rows: int, seed: int) -> dict:
    """Per family (the reference six excepted, sorted), the seeded sample of ``rows`` of its rows
    that every table here is measured on (sorted row indices)."""
    rng = np.random.default_rng(seed)
    out = {}
    for fam in sorted(set(store.family.tolist()) - {"reference"}):
        held = np.flatnonzero(store.family == fam)
        out[fam] = np.sort(rng.choice(held, min(rows, len(held)), replace=False))
    return out


def cnn_table(checkpoints: Path, rows: int, seed: int = 0) -> list[dict]:
    """Per family F with ``checkpoints/F.pt`` (a CNN trained without F: ``rap-farm train
    datasets/corpus --holdout-family F``), its metrics on the rows ``scorer`` measures, beside
    ``checkpoints/all.pt`` (the same recipe and budget on every family) where it exists."""
    import research.descriptor_scorer as ds
    from rap.model.inference.operations import OperationPredictor

    store, x = ds.corpus_rows()
    models = {}

    def scored(path: Path, pick) -> dict:
        if path not in models:
            models[path] = OperationPredictor.load(path, engine="cnn")
        return _cnn_metrics(models[path], store, x, pick)

    out = []
    for fam, pick in _picks(store, rows, seed).items():
        if not (checkpoints / f"{fam}.pt").is_file():
            continue
        row = {"family": fam, "rows": int(len(pick)),
               "cnn_lofo": scored(checkpoints / f"{fam}.pt", pick)}
        if (checkpoints / "all.pt").is_file():
            row["cnn_all"] = scored(checkpoints / "all.pt", pick)
        print(json.dumps(row), flush=True)
        out.append(row)
    return out


def plan_table(families: list[str], seeds: list[int], max_parts: int) -> list[dict]:
    from rap.geometry.families import generate
    from rap.model.inference.operations import OperationPredictor
    from rap.plan import plan
    from rap.plan.scoring.cache import ScoreCache

    out = []
    for fam in families:
        for seed in seeds:
            asm = generate(fam, seed)
            if len(asm) > max_parts:
                continue
            default = OperationPredictor.load(CHECKPOINT, engine="auto")
            trees = OperationPredictor.load(CHECKPOINT, engine="auto")
            trees.guard = None  # the cascade as it was before the guard
            cnn = OperationPredictor.load(CHECKPOINT, engine="cnn")
            row = {"assembly": asm.name, "parts": len(asm)}
            # one cache: scores are content-keyed and seeded, so R is what each would get alone;
            # the default runs first (its time from an empty cache), the optimum last (its time
            # is then a lower bound: some operations were simulated before)
            cache = ScoreCache()
            for name, kw in (("default", {"model": default}), ("trees", {"model": trees}),
                             ("cnn", {"model": cnn}), ("optimal", {"method": "optimal"})):
                t = time.perf_counter()
                r = plan(asm, cache=cache, **kw)
                row[name] = _outcome(r, t)
                if name == "default":
                    row["guard"] = (r.stats.get("guard") or {}).get("outside")
                    row["flagged"] = r.stats.get("guard") is not None
            opt = row["optimal"]["R"]
            if row["flagged"]:  # the variant that keeps a gap on a flagged assembly
                from research.variants.guard_gap import GuardGapSearchPlanner

                t = time.perf_counter()
                r = plan(asm, GuardGapSearchPlanner(), cache=ScoreCache(),
                         model=OperationPredictor.load(CHECKPOINT, engine="auto"))
                row["guard_gap"] = _outcome(r, t)
            for name in ("default", "trees", "cnn", "guard_gap")[:3 + row["flagged"]]:
                row[f"{name}_share"] = round(row[name]["R"] / opt, 3) if opt > 0 else None
            print(json.dumps(row), flush=True)
            out.append(row)
    return out


def guard_stats(out: Path, share: float, measure: bool, reference: int) -> None:
    import research.descriptor_scorer as ds
    from rap.model.inference.descriptor_model import Familiarity

    store, x = ds.corpus_rows()
    fam = Familiarity.fit(x, ds.LOG_COLUMNS, reference=reference, share=share,
                          rng=np.random.default_rng(0))
    fam.meta.update(command="python -m research.leave_one_family_out guard-stats",
                    dataset="datasets/corpus")
    if measure:
        from rap.geometry.families import FAMILIES, HELD_OUT, generate
        from rap.model.data.batch_descriptors import BatchDescriptors
        from rap.geometry.families.simple import grid, random_tiling
        from rap.model.inference.cascade import GUARD_OPERATIONS, guard_sample
        from rap.plan.problem import PlanningProblem
        from rap.sim.params import SimParams

        cases = ([(f, s, False) for f in sorted(FAMILIES) for s in (200, 201)]
                 + [(f, s, True) for f in sorted(HELD_OUT) for s in (0, 1, 2, 3)]
                 + [("grid", k, False) for k in (4, 5, 6, 8, 10)]  # sizes beyond the corpus'
                 + [("tiling", n, False) for n in (12, 20, 30, 50, 100)])
        for name, s, held_out in cases:
            asm = (grid(s) if name == "grid" else
                   random_tiling(s, np.random.default_rng(1)) if name == "tiling" else
                   generate(name, s))
            problem = PlanningProblem(asm, SimParams())
            ops = guard_sample(problem, GUARD_OPERATIONS)
            d = BatchDescriptors(asm).of(ops) if ops else np.zeros((0, 12))
            print(json.dumps({"assembly": asm.name, "parts": len(asm), "held_out": held_out,
                              "outside": round(fam.outside(d), 3), "operations": len(ops)}),
                  flush=True)
    fam.save(out)
    print(f"limit {fam.limit:.3f} ({fam.meta['quantile']} of {fam.meta['probe']} training rows "
          f"against {fam.meta['reference']}), share {share}; wrote {out}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    a1 = sub.add_parser("scorer")
    a1.add_argument("--rows", type=int, default=2000)
    a1.add_argument("--rounds", type=int, default=400)
    a1.add_argument("--families", default="", help="comma-separated (default: every family)")
    a1.add_argument("--train-rows", type=int, default=0,
                    help="fit the trees on a seeded sample of this many rows (0: all)")
    a4 = sub.add_parser("cnn")
    a4.add_argument("--checkpoints", required=True, help="a folder of FAMILY.pt (and all.pt)")
    a4.add_argument("--rows", type=int, default=2000)
    a2 = sub.add_parser("plans")
    a2.add_argument("--families", default="arch,dovetail,puzzle,bond")
    a2.add_argument("--seeds", default="0")
    a2.add_argument("--max-parts", type=int, default=8)
    a3 = sub.add_parser("guard-stats")
    a3.add_argument("--out", default=str(ROOT / "rap" / "data" / "default_model.scorer.guard.npz"))
    a3.add_argument("--share", type=float, default=0.4)
    a3.add_argument("--measure", action="store_true")
    a3.add_argument("--reference", type=int, default=60000)
    a = ap.parse_args(argv)
    if a.what == "scorer":
        scorer_table(a.rows, a.rounds, [f for f in a.families.split(",") if f],
                     train_rows=a.train_rows)
    elif a.what == "cnn":
        cnn_table(Path(a.checkpoints), a.rows)
    elif a.what == "plans":
        plan_table(a.families.split(","), [int(s) for s in a.seeds.split(",")], a.max_parts)
    else:
        guard_stats(Path(a.out), a.share, a.measure, a.reference)


if __name__ == "__main__":
    main()
