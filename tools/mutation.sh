#!/usr/bin/env bash
# Mutation testing of the compiled kernels with cosmic-ray (a manual target, not the test suite).
#
#   pip install -e '.[test,mutation]'
#   tools/mutation.sh                       # every kernel module (hours)
#   tools/mutation.sh attitude/_core/quat.py orbit/_kernels.py   # a subset
#   tools/mutation.sh orbit/_kernels.py:159-316                   # lines of a module only
#   SAMPLE=0.2 tools/mutation.sh ...        # a seeded random 20 % of the mutants
#   KEEP=1 tools/mutation.sh ...            # keep the session directory (sqlite, logs)
#
# How it works (see docs/mutation.md):
# * The tracked files are copied to a scratch directory and mutated there, never in the work
#   tree; PYTHONPATH points at the copy.
# * ATTITUDE_DISABLE_JIT=1: the kernels run as plain Python. With numba on, every mutant would
#   change the source fingerprint of the on-disk cache and recompile all kernels (10-60 s each).
#   Removing a decorator is therefore not a mutation here (it would be equivalent).
# * Each module is tested by the test files that exercise it (MODULE_TESTS below), stopped at
#   the first failure; tests that only make sense compiled are deselected.
# * Operators: arithmetic (+ - * /) and comparison swaps, unary minus, number changes, boolean
#   and loop mutations. Bitwise, floor-division, modulo, power and identity operators are
#   filtered out (on floats they are type errors or never plausible).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="${PYTHON:-python}"
TIMEOUT="${MUTATION_TIMEOUT:-300}"
OUT="${MUTATION_OUT:-$ROOT/.mutation}"  # survivors (diffs) per module, git-ignored

declare -A MODULE_TESTS=(
  [attitude/_core/quat.py]="tests/test_propagate.py tests/test_potentials.py"  # kernels only: attitude.quaternion is numpy
  [attitude/_core/potentials.py]="tests/test_potentials.py tests/test_units.py tests/test_propagate.py"
  [attitude/_core/dynamics.py]="tests/test_canonical.py tests/test_propagate.py"
  [attitude/_core/rk.py]="tests/test_propagate.py"
  [attitude/_core/tableaux.py]="tests/test_propagate.py"
  [attitude/_core/splitting.py]="tests/test_splitting.py"
  [attitude/_core/exact.py]="tests/test_exact.py"
  [attitude/_core/elliptic.py]="tests/test_elliptic.py tests/test_exact.py"
  [attitude/_core/formulations.py]="tests/test_formulations.py"
  [attitude/_core/ensemble.py]="tests/test_ensemble.py"
  [attitude/_core/entry_points.py]="tests/test_propagate.py tests/test_ensemble.py tests/test_events.py"
  [attitude/_core/events.py]="tests/test_events.py"
  [attitude/_core/environment.py]="tests/test_environment.py tests/test_torque_models.py"
  [attitude/_core/frames.py]="tests/test_frames.py"
  [attitude/_core/taylor.py]="tests/test_taylor.py"
  [orbit/_state_kernels.py]="tests/test_orbit_sources_runs.py tests/test_keplerorbit.py"
  [orbit/_kernels.py]="tests/test_kepler.py tests/test_keplerorbit.py"
)
# Tests that check compiled-only behaviour (numba typing errors, caching, calls from numba).
DESELECT=(
  "tests/test_potentials.py::test_user_potential_errors"
  "tests/test_kepler.py::test_callable_from_numba"
)

if [ "$#" -eq 0 ]; then
  set -- "${!MODULE_TESTS[@]}"
fi

WORK="$(mktemp -d "${TMPDIR:-/tmp}/attitude-mutation.XXXXXX")"
cleanup() { [ "${KEEP:-0}" = 1 ] && echo "session kept in $WORK" || rm -rf "$WORK"; }
trap cleanup EXIT
(cd "$ROOT" && git ls-files -z | xargs -0 cp --parents -t "$WORK")
cd "$WORK"
export PYTHONPATH="$WORK" ATTITUDE_DISABLE_JIT=1 PYTHONDONTWRITEBYTECODE=1

deselect=()
for d in "${DESELECT[@]}"; do deselect+=(--deselect "$d"); done

total_survivors=0
for spec in "$@"; do
  module="${spec%%:*}"
  lines=""
  [ "$spec" != "$module" ] && lines="${spec#*:}"
  tests="${MODULE_TESTS[$module]:?no test files configured for $module}"
  name="$(echo "$spec" | tr '/.:-' '____')"
  cat > "$name.toml" <<TOML
[cosmic-ray]
module-path = "$module"
timeout = $TIMEOUT
excluded-modules = []
test-command = "$PY -m pytest -x -q -p no:cacheprovider --hypothesis-seed=0 ${deselect[*]} $tests"

[cosmic-ray.distributor]
name = "local"

[cosmic-ray.filters.operators-filter]
exclude-operators = [
  "core/ReplaceBinaryOperator_.*_(BitOr|BitAnd|BitXor|LShift|RShift|FloorDiv|Mod|Pow)",
  "core/ReplaceBinaryOperator_(BitOr|BitAnd|BitXor|LShift|RShift|FloorDiv|Mod|Pow)_.*",
  "core/ReplaceComparisonOperator_.*_(Is|IsNot)",
  "core/ReplaceComparisonOperator_(Is|IsNot)_.*",
  "core/ReplaceUnaryOperator_.*(Invert|Not)",
  "core/RemoveDecorator",
  "core/ExceptionReplacer",
  "core/VariableReplacer",
  "core/VariableInserter",
]
TOML
  if [ -n "$lines" ]; then
    printf '\n[cosmic-ray.filters.line-filter]\nlines = { "%s" = ["%s"] }\n' "$module" "$lines" \
      >> "$name.toml"
  fi
  echo "== $spec: $tests"
  "$PY" -m cosmic_ray.cli init "$name.toml" "$name.sqlite"
  cr-filter-operators "$name.sqlite" "$name.toml"
  cr-filter-pragma "$name.sqlite"
  [ -n "$lines" ] && cr-filter-lines --config "$name.toml" "$name.sqlite"
  if [ -n "${SAMPLE:-}" ]; then  # keep a seeded random fraction of the pending mutants
    "$PY" - "$name.sqlite" "$SAMPLE" <<'PY'
import random, sys
from cosmic_ray.work_db import WorkDB, use_db
from cosmic_ray.work_item import WorkResult, WorkerOutcome
with use_db(sys.argv[1], WorkDB.Mode.open) as db:
    items = sorted(db.pending_work_items, key=lambda i: i.job_id)
    keep = set(random.Random(0).sample(range(len(items)), round(float(sys.argv[2]) * len(items))))
    for i, item in enumerate(items):
        if i not in keep:
            db.set_result(item.job_id, WorkResult(output="not sampled",
                                                  worker_outcome=WorkerOutcome.SKIPPED))
    print(f"sampled {len(keep)} of {len(items)} mutants")
PY
  fi
  "$PY" -m cosmic_ray.cli baseline "$name.toml"
  "$PY" -m cosmic_ray.cli exec "$name.toml" "$name.sqlite"
  s=$("$PY" - "$name.sqlite" "$name.survivors.txt" <<'PY'
import collections, sys
from cosmic_ray.work_db import WorkDB, use_db
with use_db(sys.argv[1], WorkDB.Mode.open) as db:
    done = db.completed_work_items
    n = collections.Counter()
    with open(sys.argv[2], "w") as out:
        for item, res in done:
            if res.worker_outcome == "skipped":
                n["filtered"] += 1
            elif res.worker_outcome == "normal" and res.test_outcome == "survived":
                n["survived"] += 1
                m = item.mutations[0]
                out.write(f"--- {m.module_path}:{m.start_pos[0]} {m.operator_name}\n{res.diff}\n")
            elif res.test_outcome == "killed":
                n["killed"] += 1
            else:
                n[str(res.worker_outcome)] += 1
    tested = sum(v for k, v in n.items() if k != "filtered")
    print(f"tested {tested}, killed {n['killed']}, survived {n['survived']}, other "
          f"{tested - n['killed'] - n['survived']}, filtered {n['filtered']}, "
          f"pending {sum(1 for _ in db.pending_work_items)}", file=sys.stderr)
    print(n["survived"])
PY
)
  sed 's/^/    /' "$name.survivors.txt"
  mkdir -p "$OUT" && cp "$name.survivors.txt" "$OUT/"
  total_survivors=$((total_survivors + s))
done
echo "== surviving mutants in total: $total_survivors"
