#!/usr/bin/env bash
# Mutation testing of the compiled kernels with cosmic-ray (a manual target, not the test suite).
#
#   pip install -e '.[test,mutation]'
#   tools/mutation.sh                       # every kernel module (hours)
#   tools/mutation.sh attitude/_core/quat.py orbit/_kernels.py   # a subset
#   tools/mutation.sh orbit/_kepler_equation.py:93-250            # lines of a module only
#   SAMPLE=0.2 tools/mutation.sh ...        # a seeded random 20 % of the mutants
#   SAMPLE_N=24 tools/mutation.sh ...       # a seeded random 24 mutants of each module
#   SAMPLE_SEED=1 SAMPLE_N=10 ...           # another sample (the seed; default 0)
#   TESTS="tests/test_x.py::test_y" tools/mutation.sh module.py   # other tests than the table's
#   KEEP=1 tools/mutation.sh ...            # keep the session directory (sqlite, logs)
#
# How it works (see docs/mutation.md):
# * The tracked files are copied to a scratch directory and mutated there, never in the work
#   tree; PYTHONPATH points at the copy.
# * ATTITUDE_DISABLE_JIT=1: the kernels run as plain Python. With numba on, every mutant would
#   change the source fingerprint of the on-disk cache and recompile all kernels (10-60 s each).
#   Removing a decorator is therefore not a mutation here (it would be equivalent).
# * Each module is tested by the test files that exercise it (MODULE_TESTS below), stopped at
#   the first failure, in one process (-n 0: the tests run in the order given, fast ones first);
#   tests that only make sense compiled are deselected. The actuator, flight-software and
#   sensor modules run selected tests: the rest take minutes each with the JIT disabled and
#   are run on the survivors afterwards, compiled (docs/mutation.md).
# * Operators: arithmetic (+ - * /) and comparison swaps, unary minus, number changes, boolean
#   and loop mutations. Bitwise, floor-division, modulo, power and identity operators are
#   filtered out (on floats they are type errors or never plausible).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="${PYTHON:-python}"
TIMEOUT="${MUTATION_TIMEOUT:-300}"
OUT="${MUTATION_OUT:-$ROOT/.mutation}"  # survivors (diffs) per module, git-ignored

# Selected tests of the actuator, software and sensor modules, fast ones first. Left out (they
# take 1-7 min each with the JIT disabled; run compiled on the survivors): the Taylor-against-
# DOP853 runs with gravity gradient, the MEKF consistency test (the MEKF's kernels have their
# dense-formula tests), the Allan deviation for all but the sensors.
A=tests/test_actuators.py
ACT="$A::test_friction_kernel_is_basilisks_law $A::test_speed_limit_cuts_commands_that_spin_the_wheel_further
 $A::test_wheel_on_the_symmetry_axis_spun_up_by_a_constant_torque $A::test_thruster_pair_pulse_against_the_closed_form
 $A::test_stribeck_regime_of_a_wheel_let_go_below_a_tenth_of_the_limit_cycle_speed
 $A::test_coulomb_friction_stops_a_wheel_through_the_kink_at_the_closed_form_time
 $A::test_rotor_stabilised_spin_about_the_intermediate_axis $A::test_steady_spins_of_a_gyrostat_with_a_skew_rotor
 $A::test_magnetorquers_equal_a_magnetic_dipole_of_the_same_moment $A::test_bad_actuators_and_schedules_are_refused_before_any_work
 $A::test_command_schedule_from_csv $A::test_scenario_actuators_and_commands_inline_and_from_csv
 $A::test_scenario_actuator_errors_name_the_key
 $A::test_from_tensor_with_skew_wheels_against_euler_equations_in_the_structural_frame
 $A::test_pyramid_under_a_saturating_schedule_conserves_G_and_pays_the_motor_work"
TAYLOR="$A::test_coulomb_friction_stops_a_wheel_through_the_kink_at_the_closed_form_time $A::test_taylor_order_follows_the_hold
 $A::test_taylor_equals_dop853_with_wheels_and_thrusters[torque_free] tests/test_software.py::test_wheels_alone_in_closed_loop_conserve_G_to_round_off
 tests/test_sensors.py::test_runs_are_reproducible_from_their_seeds"
S=tests/test_software.py
SOFT_FAST="$S::test_slow_pd_control_is_the_exact_zero_order_hold_discretisation $S::test_a_step_function_that_raises_keeps_the_samples_computed
 $S::test_your_own_step_function_equals_the_compiled_law $S::test_modes_delay_and_slew
 $S::test_null_space_management_spreads_the_momentum_without_a_body_torque $S::test_bad_software_is_refused_before_any_work"
SOFT="$SOFT_FAST $S::test_slew_reference_is_the_trapezoidal_rate_profile
 $S::test_your_own_step_measures_against_closed_forms_and_astropys_sun
 $S::test_your_own_mrp_law_tracking_lvlh_equals_the_compiled_law
 $S::test_mode_conditions_switch_at_the_first_tick_the_closed_form_says
 tests/test_sensors.py::test_mekf_with_a_vector_sensor_in_the_loop_is_the_filter_replayed_by_hand
 $S::test_momentum_dumping_unloads_the_wheels_at_its_gain $S::test_fast_pd_control_matches_the_second_order_response
 $S::test_wheels_alone_in_closed_loop_conserve_G_to_round_off $S::test_bdot_detumbles_the_cubesat_to_twice_the_orbital_rate"
E=tests/test_sensors.py
SENS_FSW="$E::test_runs_are_reproducible_from_their_seeds $E::test_star_tracker_and_magnetometer_noise_is_what_their_parameters_say
 $E::test_star_tracker_exclusion_flags_exactly_when_the_geometry_says"
SENS="$E::test_xoshiro256starstar_is_the_published_generator $E::test_bad_sensor_parameters_are_refused
 $E::test_normal_deviates_are_standard_normal $SENS_FSW $E::test_sun_sensor_direction_and_eclipse_against_astropys_sun
 $E::test_gyro_allan_deviation_has_the_slopes_and_levels_of_its_parameters"
MEKF="$E::test_bad_sensor_parameters_are_refused $E::test_mekf_covariance_steps_equal_the_dense_matrix_formulas
 $E::test_mekf_vector_update_and_estimation_error_against_dense_formulas
 $E::test_mekf_propagation_against_expm_at_any_rotation_per_step"
# your own step function (fsw_step.py: the measurements it sees, the checks of its commands)
STEP="$S::test_your_own_step_measures_against_closed_forms_and_astropys_sun
 $S::test_own_steps_with_three_torques_or_one_wheel_are_the_exact_hold_discretisation
 $S::test_your_own_step_function_equals_the_compiled_law $S::test_a_step_function_that_raises_keeps_the_samples_computed
 $S::test_bad_software_is_refused_before_any_work $S::test_a_compiled_step_equals_the_compiled_law
 $S::test_your_own_step_sees_what_the_sensors_and_the_estimator_give"

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
  [orbit/_kepler_equation.py]="tests/test_kepler.py tests/test_keplerorbit.py"
  # issues 24-26: actuators, flight software, sensors, estimation (selected tests: below)
  [attitude/_core/actuators.py]="$ACT"
  [attitude/_core/gyrostat.py]="$ACT"
  [attitude/_core/holds.py]="$ACT $SOFT_FAST"
  [attitude/_core/taylor_gyrostat.py]="$TAYLOR"
  [attitude/_core/fsw.py]="$SOFT $SENS_FSW"
  [attitude/_core/fsw_step.py]="$STEP"
  [attitude/_core/sensors.py]="$SENS"
  [attitude/_core/rng.py]="$SENS"
  [attitude/_core/mekf.py]="$MEKF"
  [attitude/actuators/_common.py]="$ACT"
  [attitude/actuators/commands.py]="$ACT"
  [attitude/actuators/magnetorquers.py]="$ACT"
  [attitude/actuators/thrusters.py]="$ACT"
  [attitude/actuators/wheels.py]="$ACT"
  [attitude/spacecraft.py]="$ACT"
  [attitude/_holds.py]="$ACT $SOFT_FAST"
  [attitude/control/_allocation.py]="$SOFT"
  [attitude/control/_laws.py]="$SOFT"
  [attitude/software/_guidance.py]="$SOFT"
  [attitude/software/_modes.py]="$SOFT"
  [attitude/software/_software.py]="$SOFT $SENS_FSW"
  [attitude/sensors/_models.py]="$SENS"
  [attitude/estimation/_mekf.py]="$MEKF"
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
  tests="${TESTS:-${MODULE_TESTS[$module]:?no test files configured for $module}}"
  name="$(echo "$spec" | tr '/.:-' '____')"
  cat > "$name.toml" <<TOML
[cosmic-ray]
module-path = "$module"
timeout = $TIMEOUT
excluded-modules = []
test-command = "$PY -m pytest -x -q -n 0 -p no:cacheprovider --hypothesis-seed=0 ${deselect[*]} $(echo $tests)"

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
  if [ -n "${SAMPLE:-}${SAMPLE_N:-}" ]; then  # keep a seeded random part of the pending mutants
    "$PY" - "$name.sqlite" "${SAMPLE:-}" "${SAMPLE_N:-}" "${SAMPLE_SEED:-0}" <<'PY'
import random, sys
from cosmic_ray.work_db import WorkDB, use_db
from cosmic_ray.work_item import WorkResult, WorkerOutcome
with use_db(sys.argv[1], WorkDB.Mode.open) as db:
    # in source order (job ids are random uuids: sorting on them made samples unrepeatable)
    items = sorted(db.pending_work_items, key=lambda i: (
        str(i.mutations[0].module_path), tuple(i.mutations[0].start_pos),
        i.mutations[0].operator_name, i.mutations[0].occurrence))
    n = int(sys.argv[3]) if sys.argv[3] else round(float(sys.argv[2]) * len(items))
    keep = set(random.Random(int(sys.argv[4])).sample(range(len(items)), min(n, len(items))))
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
