"""The planning problem: an assembly, its operation space, and how operations are scored.

A ``PlanningProblem`` says *what* is to be planned, never *how* (the planners) or *whether a plan
is valid* (``rap.plan.report.validate``), in the manner of OMPL's ``ProblemDefinition``:

* ``assembly``: the parts in their final placements;
* ``space``: which operations a subassembly offers. ``"online"`` is RAP's choice (one partition per
  NDBG cell, adjacent cells admitting the same partition merged, the middle direction of the merged
  range: ``rap.geometry.partitions.online_partitions``), also used by the paper for the optimal and
  random baselines; ``"all"`` every closed moving set of every cell (``all_partitions``). A
  cell that moves one part per step (``constraints.one_part``: ``--linear`` or ``--gravity``)
  offers every single-part move instead (``single_part_partitions``), in either space: the online
  choice of a cell may be a set of parts, and filtering it would lose single parts that can go;
* ``params`` and ``root_seed``: the simulator parameters and the run's root seed. An operation's
  simulator seed is ``derive_seed(root_seed, op.key(geometry_hash, params.fingerprint()))`` and its
  cache/dataset key ``rap.enumerate.label_key`` of the same, exactly as the labelling farm does, so a
  score never depends on which process or planner asked for it.

``candidates(subset)`` returns the operations that assemble ``subset`` from two of its subsets
(deduplicated by content key, in the partition function's order) that obey the problem's
``constraints`` (``rap.plan.cell.constraints.CellConstraints``: fixture, one arm, insertion cones,
gravity; applied by ``rap.plan.cell.rules``, so every planner obeys them); an empty tuple means the
subset is interlocked or blocked by the constraints. ``splits(subset)`` gives every operation
without the constraints, with its ``Partition`` (None from a ``partition_fn``); ``stability``
the memoised static check of a subassembly (``stability_fn``, default
``rap.sim.statics.check_static``). The NDBG is built once, lazily, and shared with the descriptors
and the plan's reasons (``rap.geometry.ndbg.ndbg_of``). ``partition_fn`` replaces the NDBG's
operations for tests. An operation's key and seed do not depend on the constraints.

``is_free(op)``: whether the operation's moving parts touch nothing of the fixed ones, along their
insertion or at their goal (``rap.geometry.ndbg.is_free_operation``, exact): such an operation is
robust by geometry, and the scorer gives it 1 without simulating or predicting
(``rap.plan.scoring.scorer``). Memoised; its first call builds the NDBG and the table of touching
parts.

No ray, no torch.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Callable, Iterable

from rap.assembly import Assembly
from rap.enumerate import label_key, label_seed
from rap.errors import ParameterError
from rap.operation import Operation
from rap.plan.cell.constraints import CellConstraints
from rap.seeds import DEFAULT_ROOT_SEED

__all__ = ["SPACES", "check_space", "PlanningProblem", "PartitionFn", "StabilityFn"]

SPACES = ("online", "all")

# (subset) -> iterable of Operations assembling ``subset``
PartitionFn = Callable[[frozenset], Iterable[Operation]]
# (assembly, subset, base part, unit gravity, friction) -> an object with ``stable``, ``reason``
StabilityFn = Callable[..., object]


def _ndbg_partition_fn(assembly: Assembly, space: str, one_part: bool = False) -> PartitionFn:
    """(subset) -> [(Operation, Partition)] from the NDBG; ``one_part``: every single-part move
    (``single_part_partitions``) whatever the space, for a cell that inserts one part a step."""
    from rap.geometry import partitions as P
    from rap.geometry.ndbg import ndbg_of

    ndbg = ndbg_of(assembly)
    choose = P.online_partitions if space == "online" else P.all_partitions
    if one_part:
        choose = P.single_part_partitions

    def fn(subset: frozenset) -> list[tuple[Operation, object]]:
        return [(p.operation(), p) for p in choose(ndbg, frozenset(subset))]

    return fn


def check_space(space: str) -> None:
    """``ParameterError`` (parameter ``space``) unless ``space`` is one of ``SPACES``."""
    if space not in SPACES:
        raise ParameterError("space", space, f"choose {' or '.join(SPACES)}")


@dataclass
class PlanningProblem:
    """Plan an assembly sequence for ``assembly`` over the operation ``space`` (see module doc)."""

    assembly: Assembly
    params: object  # rap.sim.params.SimParams (anything with ``fingerprint()``)
    root_seed: int = DEFAULT_ROOT_SEED
    space: str = "online"
    partition_fn: PartitionFn | None = field(default=None, repr=False)
    constraints: CellConstraints = CellConstraints()
    stability_fn: StabilityFn | None = field(default=None, repr=False)
    _cache: dict = field(default_factory=dict, init=False, repr=False)
    _splits: dict = field(default_factory=dict, init=False, repr=False)
    _stable: dict = field(default_factory=dict, init=False, repr=False)
    _ndbg_fns: dict = field(default_factory=dict, init=False, repr=False)  # one_part -> fn
    cell_memo: dict = field(default_factory=dict, init=False, repr=False)  # rap.plan.cell.rules's
    _free: dict = field(default_factory=dict, init=False, repr=False)  # op content -> is free
    _lock: threading.Lock = field(default_factory=threading.Lock, init=False, repr=False)

    def __post_init__(self):
        check_space(self.space)
        self.root_seed = int(self.root_seed)
        self.constraints.check(self.assembly)

    # -- identity of operations -----------------------------------------------------------------
    @property
    def whole(self) -> frozenset[str]:
        return frozenset(self.assembly.ids)

    @property
    def geometry_hash(self) -> str:
        return self.assembly.geometry_hash

    @property
    def params_fingerprint(self) -> str:
        return self.params.fingerprint()

    def key(self, op: Operation) -> str:
        """Cache key of an operation's score: content key + simulator parameters + root seed."""
        return label_key(op, self.geometry_hash, self.params_fingerprint, self.root_seed)

    def seed(self, op: Operation) -> int:
        """The simulator seed of an operation (the labelling farm's ``label_seed``)."""
        return label_seed(op, self.geometry_hash, self.params_fingerprint, self.root_seed)

    # -- the operation space --------------------------------------------------------------------
    def splits(self, subset: Iterable[str], one_part: bool | None = None
               ) -> tuple[tuple[Operation, object], ...]:
        """Every operation assembling ``subset`` without the constraints, with its ``Partition``
        (None where ``partition_fn`` gave it), deduplicated by content key in the partition
        function's order (empty when interlocked). ``one_part``: the single-part moves (module
        doc; None: when the constraints move one part per step). Memoised; thread-safe."""
        subset = frozenset(subset)
        one_part = self.constraints.one_part if one_part is None else bool(one_part)
        with self._lock:
            hit = self._splits.get((subset, one_part))
            if hit is not None:
                return hit
            if self.partition_fn is None and one_part not in self._ndbg_fns:
                self._ndbg_fns[one_part] = _ndbg_partition_fn(self.assembly, self.space,
                                                              one_part)
            user, ndbg = self.partition_fn, self._ndbg_fns.get(one_part)
        seen: dict[str, tuple[Operation, object]] = {}
        if len(subset) >= 2:
            gh = self.geometry_hash
            pairs = ((op, None) for op in user(subset)) if user is not None else ndbg(subset)
            for op, part in pairs:
                if op.subassembly != subset:
                    raise ValueError(f"partition function returned {op.describe()} for "
                                     f"{{{','.join(sorted(subset))}}}")
                seen.setdefault(op.key(gh), (op, part))
        out = tuple(seen.values())
        with self._lock:
            self._splits[(subset, one_part)] = out
        return out

    def candidates(self, subset: Iterable[str]) -> tuple[Operation, ...]:
        """Operations assembling ``subset`` that obey the constraints (empty when interlocked or
        blocked). Memoised; thread-safe."""
        subset = frozenset(subset)
        with self._lock:
            hit = self._cache.get(subset)
            if hit is not None:
                return hit
        if self.constraints.active:
            from rap.plan.cell.rules import constrained_candidates

            ops = constrained_candidates(self, subset, self.constraints)
        else:
            ops = tuple(op for op, _ in self.splits(subset))
        with self._lock:
            self._cache[subset] = ops
        return ops

    def stability(self, subset: Iterable[str]):
        """The static check of ``subset`` standing on the base under the constraints' gravity
        (``stability_fn``, default ``rap.sim.statics.check_static``): an object with ``stable``
        and ``reason``. Memoised per subset; precondition: ``constraints.gravity`` is set."""
        subset = frozenset(subset)
        with self._lock:
            hit = self._stable.get(subset)
        if hit is not None:
            return hit
        fn = self.stability_fn
        if fn is None:
            from rap.sim.statics import check_static as fn
        c = self.constraints
        support = fn(self.assembly, subset, c.base, c.gravity_unit(), c.friction)
        with self._lock:
            self._stable[subset] = support
        return support

    def is_free(self, op: Operation) -> bool:
        """Whether ``op``'s moving parts touch no fixed part along the insertion or at the goal
        (module doc): robust by geometry. Exact, on the operation's exact direction where it
        carries one (else its float direction, read exactly). Memoised; thread-safe."""
        d = op.exact_direction if op.exact_direction is not None else op.direction
        memo = (op.moving, op.fixed, tuple(d))
        hit = self._free.get(memo)
        if hit is None:
            from rap.geometry.contacts import meeting_pairs
            from rap.geometry.ndbg import is_free_operation, ndbg_of

            removal = (-Fraction(d[0]), -Fraction(d[1]))
            hit = is_free_operation(ndbg_of(self.assembly), meeting_pairs(self.assembly),
                                    op.moving, op.fixed, removal)
            self._free[memo] = hit
        return hit

    def is_interlocked(self, subset: Iterable[str]) -> bool:
        subset = frozenset(subset)
        return len(subset) >= 2 and not self.candidates(subset)
