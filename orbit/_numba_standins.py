"""Faster stand-ins for three of numba's compiler passes, in place only while one of the
package's kernels compiles (docs/cold_start.md, item 6).

Each gives the same IR as numba's own (tests/test_numba_standins.py compares the LLVM IR of
package kernels compiled with and without them, and of a user's function compiled with and
without ``import attitude``). :func:`install` registers the ``numba:compile`` listener that
swaps them in and out; ``ATTITUDE_NUMBA_STANDINS=0`` leaves numba's own everywhere.
"""

from __future__ import annotations

import os
import sys


class _InlinerCopy:
    """numba's IR inliner (``inline="always"``) copies the callee's IR block by block, a fresh
    ``copy.deepcopy`` memo per block: every block copies the function's whole scope (all its
    variables) again, O(blocks x variables). The inlined flight-software tick (hundreds of
    blocks, thousands of variables) took 18 s of a closed-loop driver's 30 s compile in that
    copy (numba issue #8989). This stands for the ``copy`` module in
    :mod:`numba.core.inline_closurecall`: the blocks of one copy share one memo, so each object
    is copied once, as one ``deepcopy`` of the function would; every other call goes to
    ``copy`` itself. And when the inliner inlines a function (``InlineWorker.inline_function``)
    the IR it copies was built for that call site alone, by the untyped pipeline a moment before,
    and its second copy (an untouched one, returned) is thrown away by numba's only caller: both
    copies are skipped there. The inlined IR is the same, so the same machine code (checked: the
    LLVM IR of every function of a closed-loop run, and of runs of every method, is byte for
    byte the same with and without this).
    """

    def __init__(self, copy_module, copy_ir_code, fresh_code):
        self._copy = copy_module
        self._code = copy_ir_code
        self._fresh = fresh_code  # InlineWorker.inline_function: a fresh IR, used once
        self._frame = None  # the copy in progress (its frame), its memo, its blocks to go
        self._memo: dict = {}
        self._left = 0

    def __getattr__(self, name):
        return getattr(self._copy, name)

    def deepcopy(self, x, memo=None):
        if memo is None:
            f = sys._getframe(1)
            if f.f_code is self._code:  # a block of copy_ir's loop
                caller = f.f_back.f_back  # (copy_ir <- inline_ir <- its caller)
                if caller is not None and caller.f_code is self._fresh:
                    return x
                if self._frame is not f:
                    self._frame, self._memo = f, {}
                    self._left = len(f.f_locals["the_ir"].blocks)
                out = self._copy.deepcopy(x, self._memo)
                self._left -= 1
                if self._left <= 0:  # the copy is complete: nothing kept alive
                    self._frame, self._memo = None, {}
                return out
        return self._copy.deepcopy(x, memo)


def _ssa_in_touched_blocks(ssa, ir, errors):
    """numba's SSA reconstruction (``numba.core.ssa._run_ssa``), rewriting for each variable
    only the blocks that name it.

    numba fixes one variable assigned more than once at a time, and rebuilds every block of the
    function for each (twice: fresh names for its definitions, then its uses and phi nodes): in
    the inlined closed-loop drivers, thousands of blocks for each of thousands of such variables,
    a tenth of a driver's compile time. The blocks that do not name the variable come out of
    numba's passes unchanged (its handlers return their statements as they are), so here they
    are skipped: numba's own handlers run on the same statements in the same order, and the
    result is the same IR (the same names, phi nodes and statements; checked: the LLVM IR of
    every function of the closed-loop, ensemble and single runs byte for byte the same).
    """

    def rewrite(blocks, labels, states, handler):
        for label in labels:
            blk = blocks[label]
            new = ir.Block(scope=blk.scope, loc=blk.loc)
            states["label"] = label
            states["block"] = blk
            body = []
            for stmt in ssa._run_ssa_block_pass(states, blk, handler):
                assert stmt is not None
                body.append(stmt)
            new.body = body
            blocks[label] = new

    def run_ssa(blocks):
        if not blocks:
            return {}
        cfg = ssa.compute_cfg_from_blocks(blocks)
        df_plus = ssa._iterated_domfronts(cfg)
        violators = ssa._find_defs_violators(blocks, cfg)
        if violators:
            named: dict = {}  # variable name -> labels of the blocks whose statements name it
            for label, blk in blocks.items():
                for stmt in blk.body:
                    for var in stmt.list_vars():
                        named.setdefault(var.name, set()).add(label)
            copies = {}
            for label, blk in blocks.items():  # (numba returns new blocks: so does this)
                copies[label] = new = ir.Block(scope=blk.scope, loc=blk.loc)
                new.body = list(blk.body)
            blocks = copies
            cache_list_vars = ssa._CacheListVars()
            for varname in violators:
                where = named.get(varname, ())
                labels = [label for label in blocks if label in where]
                states = ssa._make_states(blocks)
                states["varname"] = varname
                states["defmap"] = defmap = ssa.defaultdict(list)
                rewrite(blocks, labels, states, ssa._FreshVarHandler())
                states = ssa._make_states(blocks)
                states["varname"] = varname
                states["defmap"] = defmap
                states["phimap"] = phimap = ssa.defaultdict(list)
                states["cfg"] = cfg
                states["phi_locations"] = ssa._compute_phi_locations(df_plus, defmap)
                rewrite(blocks, labels, states, ssa._FixSSAVars(cache_list_vars))
                for label, philist in phimap.items():
                    blk = blocks[label]
                    blk.body = philist + blk.body
        if ssa.compute_cfg_from_blocks(blocks) != cfg:
            raise errors.CompilerError("CFG mutated in SSA pass")
        return blocks

    return run_ssa


def _flags_comparison(tc):
    """``__hash__`` and ``__eq__`` for numba's ``TargetConfig`` (the compile flags), or None if
    numba's are not the ones these stand for.

    Typing looks every overloaded operation up in a cache keyed on the flags, about 10^5 times
    for a closed-loop driver; each lookup hashes them and compares them with
    ``values()``, a dictionary of every option (about 40, each read through a property):
    ~5 % of a cold compile. The hash is the same number (numba's hashes the sorted option
    names: ``sorted`` of a dictionary is its keys); the comparison looks only at the options
    set on either side (the others are their defaults on both), with the same equality, so
    every lookup finds what it found before.
    """
    base = tc.TargetConfig
    if (
        "_values" not in base.__slots__
        or not {"sorted", "values"} <= set(base.__hash__.__code__.co_names)
        or "values" not in base.__eq__.__code__.co_names
    ):
        return None
    numba_eq, numba_hash = base.__eq__, base.__hash__

    def __hash__(self):
        return hash(tuple(sorted(self.options)))

    def __eq__(self, other):
        if not isinstance(other, base):
            return NotImplemented
        opts = self.options
        if type(other).options is not opts:
            return numba_eq(self, other)
        a, b = self._values, other._values
        for k in a.keys() | b.keys():
            d = opts[k].default
            x, y = a.get(k, d), b.get(k, d)
            if not (x is y or x == y):
                return False
        return True

    # the same answers as numba's on flags differing in set, unset and default-valued options
    from numba.core.compiler import Flags

    f = [Flags() for _ in range(4)]
    f[1].nrt = True
    f[2].nrt = True
    f[2].fastmath = True
    f[3].nrt = Flags.options["nrt"].default
    for x in f:
        for y in f:
            if __eq__(x, y) != numba_eq(x, y) or __hash__(x) != numba_hash(x):
                return None
    return __hash__, __eq__


class _StandIns:
    """The stand-ins swapped into numba while one of the package's kernels compiles (with what
    it compiles along: its callees, numba's overloads), and numba's own put back when it ends.

    A ``numba:compile`` listener counts nested compilations: the swap happens when the outermost
    compilation is of a function whose code is the package's (a kernel, or a copy of one made by
    :func:`specialise` or :func:`rebind`) and is undone when that compilation ends, so a numba
    function of anyone else, compiled on its own, goes through numba's passes untouched
    (tests/test_numba_standins.py compares its LLVM IR with and without ``import attitude``).
    numba compiles under one global lock, so the count is never interleaved. Each stand-in is
    left out if numba's internals are not the ones it was written for (numba is pinned to 0.68).
    """

    def __init__(self) -> None:
        self.depth = 0
        self.swaps: list | None = None  # (owner, attribute, stand-in, numba's own)
        self.active = False
        self.used = 0  # how many compilations ran with them (tests read it)
        self.packages: tuple[str, ...] = ()  # the package directories (with a trailing sep)

    def _build(self) -> list:
        import copy

        from numba.core import errors, ir, ssa, targetconfig
        from numba.core import inline_closurecall as ic

        swaps = []
        code = next(
            (
                c
                for c in ic.InlineWorker.inline_ir.__code__.co_consts
                if getattr(c, "co_name", None) == "copy_ir"
            ),
            None,
        )
        fresh = ic.InlineWorker.inline_function.__code__
        if code is not None and ic.copy is copy and fresh.co_names[:1] == ("run_untyped_passes",):
            swaps.append((ic, "copy", _InlinerCopy(copy, code, fresh), copy))
        names = (
            "_iterated_domfronts _find_defs_violators _CacheListVars _make_states "
            "_FreshVarHandler _FixSSAVars _compute_phi_locations _run_ssa_block_pass "
            "compute_cfg_from_blocks defaultdict"
        ).split()
        steps = ("_fresh_vars", "_fix_ssa_vars", "_CacheListVars", "_find_defs_violators")
        if all(hasattr(ssa, n) for n in names) and all(
            n in ssa._run_ssa.__code__.co_names for n in steps
        ):
            swaps.append((ssa, "_run_ssa", _ssa_in_touched_blocks(ssa, ir, errors), ssa._run_ssa))
        methods = _flags_comparison(targetconfig)
        if methods is not None:
            tc = targetconfig.TargetConfig
            swaps.append((tc, "__hash__", methods[0], tc.__dict__["__hash__"]))
            swaps.append((tc, "__eq__", methods[1], tc.__dict__["__eq__"]))
        return swaps

    def _swap(self, on: bool) -> None:
        if self.swaps is None:
            self.swaps = self._build()
        for owner, name, standin, own in self.swaps:
            setattr(owner, name, standin if on else own)
        self.active = on
        self.used += on and bool(self.swaps)

    def start(self, dispatcher) -> None:
        if self.depth == 0 and self._ours(dispatcher):
            self._swap(True)
        self.depth += 1

    def _ours(self, dispatcher) -> bool:
        code = getattr(getattr(dispatcher, "py_func", None), "__code__", None)
        return code is not None and os.path.abspath(code.co_filename).startswith(self.packages)

    def end(self) -> None:
        self.depth -= 1
        if self.depth == 0 and self.active:
            self._swap(False)


STANDINS = _StandIns()


def install(package_dirs: tuple[str, ...]) -> None:
    """Listen to numba's compilations for :data:`STANDINS` (numba's event module only: its
    compiler's modules are imported on the first swap, which only a compilation needs)."""
    from numba.core import event

    STANDINS.packages = tuple(package_dirs)

    class _Listener(event.Listener):
        def on_start(self, ev):
            STANDINS.start(ev.data.get("dispatcher"))

        def on_end(self, ev):
            STANDINS.end()

    event.register("numba:compile", _Listener())


#: ``ATTITUDE_NUMBA_STANDINS=0``: numba's own inliner copy, SSA pass and flags comparison for the
#: package's kernels too (the stand-ins are only ever in place while a package kernel compiles).
NUMBA_STANDINS: bool = os.environ.get("ATTITUDE_NUMBA_STANDINS", "1") not in ("", "0")
