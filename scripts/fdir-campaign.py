#!/usr/bin/env python3
"""One table row of an FDIR campaign (issue 42; docs/fdir.md "Campaigns").

Reads a merged or run campaign directory (runs/*/result.json, each with its run's summary)
and prints: runs, detected, the 95 % one-sided Clopper-Pearson lower bound on the detection
probability, the latency from the fault's first step in force to its detection
(median / p95 / max), the isolated-as counts, the wrong-unit count, the false alarms, the
mode at the onset, and the outcome figures of the class. Standard library only.

    scripts/fdir-campaign.py DIR --class tracker|gyro|gyro-bias-step|magnetometer|wheel|gnss|undetected|nominal [--refly SIM_HOST] [--nominal NOMINAL_DIR]
    scripts/fdir-campaign.py --self-test

Exit status 1 when a run errored, a fault was missed or isolated as another unit, a false
alarm was raised (any event in a nominal run), or a run missed the class's outcome (below).
The summary's estimation_error_max_deg covers the whole run (the MEKF's start in the
detumble too), an upper bound on the error after the onset; with --refly, each tracker run
whose whole-run maximum is not below the bound is flown again (SIM_HOST run, CSV) and judged
on its est_error_deg from the fault's first step in force on. For gyro-bias-step, --refly
flies every run again for its pointing error (error_deg) from the fault's first step in force
on; the class prints the latency per magnitude decade, the isolation (the injected axis,
ambiguous, another axis) and the missed steps with their magnitudes and pointing cost.
For magnetometer, a stuck axis and a bias of at least MAG_MUST_DETECT_T must be detected
(a smaller bias across the field may not show in its magnitude before the run ends: reported)
and the run must end in hold within HOLD_DEG; the event names the injected axis or the
magnetometer (ambiguous). For wheel, every fault must be detected but a tachometer noise
factor below TACH_NOISE_MUST_DETECT or a friction factor below FRICTION_MUST_DETECT (reported
per factor: a slightly noisier tachometer may stay under the floor while the wheel works, a
speed loop absorbs a small friction). A missed bias step below BIAS_MUST_DETECT_RAD_S is reported, not failed (a small step may be
absorbed by the filter's bias random walk: docs/fdir.md "Gyro bias step").
For undetected (a fault class the flight code has no monitor for: gyro noise and saturation,
a dead sun-sensor head, a GNSS jump, a magnetorquer rod open or reversed), the run's verdict
is an outcome, not an error: a run passes when its verdict is not ok (the simulator said it
lost control: a non-zero exit) or when it ends in hold within HOLD_DEG or in sun-safe at
rest; an ok run that ended anywhere else is a silent loss of pointing and fails. The table
groups the runs by kind and magnitude decade with their verdicts and final errors. The gnss
class (a GNSS position jump, [fdir.gnss]) is judged the same way, and every jump must be
detected. A run without a mode manager (final_mode null: the paper scenarios, e.g. the CMG
and thruster campaigns) has no hold to end in: it is judged by its final true error
(final_error_deg) or, when the summary has it, the APE 95 % over [performance] from_s to
the end (pointing.ape_deg.total: the campaign bases set from_s to the last 60 s, the window
the simulator's pointing_degraded verdict judges; a limit cycle's final sample may fall on
a peak or a trough) against the scenario's own settle bound (summary settle_bound_deg, the
[performance] settle_bound_deg, default SETTLE_BOUND_DEG = 1 deg): the error the scenario
itself calls settled, the bound of its settle_time_s, so each campaign base states its own
(paper 000 times its manoeuvres to 1 deg; campaigns/base-thruster-fault.toml sets 2 deg,
above paper 004's healthy PWPF limit cycle). An ok run beyond it is a silent degradation and
fails. The table then adds the final error per magnitude decade and per unit, the ok runs
beyond the bound, the APE 95 % over [performance] from_s to the end, the
time from which the error stays within the bound to the end (settle_time_s), and the propellant (summary propellant_kg, thrusters)
with the runs above the scenario's budget (summary propellant_budget_kg, [performance]
propellant_budget_kg: the simulator's propellant_exceeded verdict, which a lost or degraded
pointing wins over, so the count includes runs with those statuses); an ok run above the
budget would be a silent drain and fails; with
--nominal NOMINAL_DIR (the same campaign's fault-free twin: same seed and dispersion keys, so
run i flew the same initial attitude) each run's propellant and final error are set against
its twin's.
Quantiles are nearest-rank (the ceil(q n)-th smallest value).
"""
import argparse
import glob
import json
import math
import csv
import os
import subprocess
import sys
import tempfile

ALPHA = 0.05
EST_MAX_DEG = 5.0  # tracker: the estimate never follows the bad tracker
# tracker: a run ending in hold goes on on the Sun and the field until the estimate's largest
# per-axis 1 sigma passes lost_attitude_sigma_deg = 0.1, i.e. a total-angle RMS up to
# sqrt(3) 0.1 deg: within 3 of those of its target
HOLD_DEG = 3.0 * math.sqrt(3.0) * 0.1
SAFE_WITHIN_S = 30.0  # gyro: sun-safe within this of the detection
AT_REST_RAD_S = math.radians(0.5)  # sun-safe "at rest": |w| below the search rate
# gyro-bias-step: a missed step at or above this is a failure (the shipped test declares
# 1e-4 rad/s in 5 s; smaller ones may be absorbed by the filter), below it a reported miss
BIAS_MUST_DETECT_RAD_S = 1.0e-3
# magnetometer: a bias at or above this must be detected (5x the test's 1.12 uT threshold
# on the field magnitude: seen unless nearly perpendicular to the field for the whole run)
MAG_MUST_DETECT_T = 5.0e-6
# wheel tach_noise: a factor at or above this must be detected. The residual of a tachometer
# with noise f sigma_t is noise of sigma_r(f) = (I_w/dt) sqrt(2 (f^2 sigma_t^2 + q^2/12 +
# sigma_g^2)); on scenarios/fdir/wheel-tach-noise-6u.toml (sigma_t = 5e-5 rad/s) the 5e-8 N m
# floor is 1.38 sigma_r at f = 8: 17 % of steps exceed and 4 of 6 fires within seconds
# (docs/fdir.md "Campaigns"). Below it a miss is reported, not failed: the wheel still works.
TACH_NOISE_MUST_DETECT = 8.0
# wheel friction: a factor at or above this must be detected. The accurate wheel's speed loop
# (rate p = 2.5 1/s) returns the delivered torque to the command after a friction step dT, so
# the residual is dT e^(-p t): its fourth 0.25 s step keeps 0.11 dT, and a step is declared
# when dT = (f - 1)(T_c + lambda |w_w|) passes about 9 floors; on
# scenarios/fdir/wheel-friction-accurate.toml (T_c = 0.04 N m, floor 0.05 N m) that holds at
# any speed from f = 12.25 on (the next factor the campaign draws: 15). A rotor at rest does
# not feel it (the Dahl state moves with the speed) until it turns.
FRICTION_MUST_DETECT = 15.0
# undetected, without a mode manager: the settle bound when the summary does not give one (the
# [performance] settle_bound_deg default, docs/scenario.md)
SETTLE_BOUND_DEG = 1.0


def binom_tail_ge(k, n, p):
    """P(X >= k), X ~ B(n, p), summed in logs (exact up to rounding)."""
    if k <= 0:
        return 1.0
    if p <= 0.0:
        return 0.0
    if p >= 1.0:
        return 1.0
    lp, lq = math.log(p), math.log1p(-p)
    terms = [
        math.lgamma(n + 1) - math.lgamma(j + 1) - math.lgamma(n - j + 1) + j * lp + (n - j) * lq
        for j in range(k, n + 1)
    ]
    top = max(terms)
    return min(1.0, math.exp(top) * sum(math.exp(t - top) for t in terms))


def cp_lower(k, n, alpha=ALPHA):
    """One-sided Clopper-Pearson lower bound: the p with P(X >= k | p) = alpha (bisection)."""
    if k == 0:
        return 0.0
    lo, hi = 0.0, 1.0
    for _ in range(200):  # the tail increases with p
        mid = 0.5 * (lo + hi)
        if binom_tail_ge(k, n, mid) < alpha:
            lo = mid
        else:
            hi = mid
    return lo


def self_test():
    """The bound against its closed forms: k = n gives alpha^(1/n), k = 1 gives 1-(1-alpha)^(1/n)."""
    cases = [(300, 300, ALPHA ** (1 / 300)), (20, 20, ALPHA ** (1 / 20))]
    cases += [(1, 300, 1 - (1 - ALPHA) ** (1 / 300)), (1, 10, 1 - (1 - ALPHA) ** (1 / 10))]
    ok = True
    for k, n, want in cases:
        got = cp_lower(k, n)
        good = abs(got - want) <= 1e-9 * max(want, 1e-3)
        ok &= good
        print(f"k={k} n={n}: {got:.9f} closed form {want:.9f} {'ok' if good else 'FAIL'}")
    good = f"{cp_lower(300, 300):.5f}" == "0.99006"
    ok &= good
    print(f"n=300, alpha=0.05: {cp_lower(300, 300):.5f} (0.99006) {'ok' if good else 'FAIL'}")
    ok &= self_test_no_mode()
    return 0 if ok else 1


def self_test_no_mode():
    """The judging of a run without a mode manager (undetected), against hand-stated verdicts:
    the final error against the summary's settle bound (or SETTLE_BOUND_DEG), the lost-control
    verdict passing whatever the error, a mode manager's run judged as before."""
    def run(err, status="ok", bound=None, mode=None, ape=None, prop=None, budget=None):
        s = {"run_status": status, "final_mode": mode, "final_error_deg": err, "final_rate_rad_s": [0.0] * 3}
        if prop is not None:
            s["propellant_kg"] = prop
        if budget is not None:
            s["propellant_budget_kg"] = budget
        if ape is not None:
            s["pointing"] = {"from_s": 120.0, "ape_deg": {"total": ape}}
        s["faults"] = [{"unit": "thruster.0", "kind": "stuck_open", "onset_s": 1.0, "injected_at_s": 1.0}]
        if bound is not None:
            s["settle_bound_deg"] = bound
        return s
    cases = [
        ("within the default 1 deg", run(0.5), True),
        ("ok beyond the default 1 deg: silent degradation", run(1.5), False),
        ("within a stated 2 deg", run(1.5, bound=2.0), True),
        ("ok beyond a stated 2 deg", run(9.0, bound=2.0), False),
        ("control_lost far off: the verdict said so", run(36.0, status="control_lost"), True),
        ("no final error, ok", run(None), False),
        ("NaN final error, ok", run(math.nan), False),
        ("a limit cycle's peak at the end, its APE within 2 deg", run(2.1, bound=2.0, ape=1.5), True),
        ("a limit cycle's trough at the end, its APE beyond 2 deg", run(0.3, bound=2.0, ape=2.5), False),
        ("pointing_degraded far off: the verdict said so", run(9.0, status="pointing_degraded", ape=9.0), True),
        ("propellant_exceeded within the bound: the verdict said so", run(0.5, status="propellant_exceeded", prop=0.2, budget=0.1), True),
        ("ok within the bound and the budget", run(0.5, prop=0.05, budget=0.1), True),
        ("ok within the bound, at the budget", run(0.5, prop=0.1, budget=0.1), True),
        ("ok within the bound, above the budget: silent drain", run(0.5, prop=0.1000001, budget=0.1), False),
        ("ok within the bound, NaN propellant against a budget", run(0.5, prop=math.nan, budget=0.1), False),
        ("ok within the bound, no budget", run(0.5, prop=5.0), True),
        ("ok within the bound, no propellant used against a budget", run(0.5, prop=0.0, budget=0.1), True),
        ("mode manager, hold within HOLD_DEG (bound ignored)", run(0.5, mode="hold", bound=0.1), True),
        ("mode manager, hold beyond HOLD_DEG", run(0.6, mode="hold", bound=2.0), False),
    ]
    ok = True
    for name, s, want in cases:
        got, fig = outcome("undetected", s, None, False)
        good = got == want
        ok &= good
        print(f"undetected, {name}: passed {got} (want {want}) {'ok' if good else 'FAIL'}")
    return ok


def quantile(xs, q):
    xs = sorted(xs)
    return xs[max(0, math.ceil(q * len(xs)) - 1)] if xs else None


def spread(xs, fmt="{:.2f}"):
    if not xs:
        return "-"
    vals = (quantile(xs, 0.5), quantile(xs, 0.95), max(xs))
    return " / ".join(fmt.format(v) for v in vals)


def load(dirname):
    out = []
    for path in sorted(glob.glob(os.path.join(dirname, "runs", "*", "result.json"))):
        with open(path) as f:
            r = json.load(f)
        out.append((path, r.get("status"), r.get("summary") or {}))
    return out


def mode_at(summary, t_s):
    mode = None
    for m in summary.get("mode_transitions") or []:
        if m["t_s"] <= t_s:
            mode = m["to"]
    return mode or "initial"


def first_entry_after(summary, mode, t_s):
    for m in summary.get("mode_transitions") or []:
        if m["t_s"] >= t_s and m["to"] == mode:
            return m["t_s"]
    return None


def post_onset_est_max(sim_host, result_path, t0_s, column="est_error_deg"):
    """Re-fly one run (its scenario.toml beside result.json) and take the largest
    value of column (est_error_deg, error_deg) from t0_s on (a NaN row, the filter
    restarting, is skipped)."""
    scen = os.path.join(os.path.dirname(result_path), "scenario.toml")
    with tempfile.TemporaryDirectory() as out:
        cmd = [sim_host, "run", scen, "--out", out, "--format", "csv", "--no-plots", "-q"]
        subprocess.run(cmd, check=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with open(os.path.join(out, "timeseries.csv")) as f:
            rows = [r for r in csv.DictReader(f) if float(r["t_s"]) >= t0_s]
    # an empty field is a non-finite value (docs/outputs.md): the filter not running
    vals = [float(r[column]) for r in rows if r[column] not in ("", "NaN")]
    vals = [v for v in vals if not math.isnan(v)]
    return max(vals) if vals else None


def count(d, key):
    d[key] = d.get(key, 0) + 1


def outcome_undetected(s, fig, det_s, bad, rate):
    """undetected and gnss: the verdict, else the end (hold, sun-safe at rest, or without a
    mode manager the final error within the settle bound); see the module doc."""
    f0 = (s.get("faults") or [{}])[0]
    fig["kind"], fig["magnitude"], fig["unit"] = f0.get("kind"), f0.get("magnitude"), f0.get("unit")
    fig["detected"] = det_s is not None
    fig["verdict"] = s.get("run_status")
    fig["mode_at_onset"] = mode_at(s, f0.get("injected_at_s") or f0.get("onset_s"))
    fig["propellant_kg"] = s.get("propellant_kg")
    fig["budget_kg"] = s.get("propellant_budget_kg")
    # above the budget (a NaN or missing use is above it), whatever the run's status
    used = math.nan if fig["propellant_kg"] is None else fig["propellant_kg"]
    fig["over_budget"] = fig["budget_kg"] is not None and not used <= fig["budget_kg"]
    fig["bound_deg"] = s.get("settle_bound_deg") or SETTLE_BOUND_DEG
    err = fig["final_error_deg"]
    fig["off"] = err is None or not err < fig["bound_deg"]  # a NaN is off
    # the APE over [performance] from_s to the end: the whole end window, not one sample
    pointing = s.get("pointing") or {}
    fig["ape_from_s"] = pointing.get("from_s")
    fig["ape_deg"] = (pointing.get("ape_deg") or {}).get("total")
    fig["settle_time_s"] = s.get("settle_time_s")  # below the bound from then to the end
    if fig["final_mode"] is None:  # no mode manager: the end window's APE, else the final error
        if fig["ape_deg"] is not None:
            fig["off"] = not fig["ape_deg"] <= fig["bound_deg"]
        kept = not fig["off"]
    else:
        kept = (fig["final_mode"] == "hold" and (err or math.inf) < HOLD_DEG) or (
            fig["final_mode"] == "sun_safe" and rate < AT_REST_RAD_S
        )
    # an ok run above the budget: the simulator's propellant_exceeded restated
    return (fig["verdict"] != "ok" or (kept and not fig["over_budget"])) and not bad, fig


def outcome(cls, s, det_s, bad, refly=None):
    """The class's outcome for one run: (passed, figures); refly() gives the estimate's
    largest error after the onset (None: not available)."""
    # a diverged run's final rate (null or astronomical components) is no outcome
    rate = math.sqrt(sum(math.nan if w is None else w * w for w in s.get("final_rate_rad_s") or [math.nan] * 3))
    rate = math.nan if s.get("run_status") == "diverged" else rate
    fig = {"final_mode": s.get("final_mode"), "final_rate_rad_s": rate, "final_error_deg": s.get("final_error_deg")}
    safe = first_entry_after(s, "sun_safe", det_s) if det_s is not None else None
    fig["to_safe_s"] = None if safe is None else safe - det_s
    if cls == "tracker":
        fig["est_max_deg"] = s.get("estimation_error_max_deg")
        fig["final_error_deg"] = s.get("final_error_deg")
        est_ok = fig["est_max_deg"] is not None and fig["est_max_deg"] < EST_MAX_DEG
        if not est_ok and refly is not None:
            fig["est_post_onset_max_deg"] = refly()
            est_ok = fig["est_post_onset_max_deg"] is not None and fig["est_post_onset_max_deg"] < EST_MAX_DEG
        end_ok = (fig["final_mode"] == "hold" and s.get("final_error_deg", math.inf) < HOLD_DEG) or (
            fig["final_mode"] == "sun_safe" and rate < AT_REST_RAD_S
        )
        return est_ok and end_ok, fig
    if cls == "gyro":
        ok = fig["to_safe_s"] is not None and fig["to_safe_s"] <= SAFE_WITHIN_S
        return ok and fig["final_mode"] == "sun_safe" and rate < AT_REST_RAD_S, fig
    if cls == "gyro-bias-step":
        f0 = (s.get("faults") or [{}])[0]
        fig["magnitude"] = f0.get("magnitude")
        fig["detected"] = det_s is not None
        fig["latency_s"] = None if det_s is None else det_s - f0.get("injected_at_s")
        fig["mode_at_onset"] = mode_at(s, f0.get("injected_at_s") or f0.get("onset_s"))
        fig["estimator_resets"] = s.get("estimator_resets")
        fig["err_post_onset_max_deg"] = refly() if refly is not None else None
        must = abs(fig["magnitude"] or 0.0) >= BIAS_MUST_DETECT_RAD_S
        return (fig["detected"] or not must) and not bad, fig
    if cls == "magnetometer":
        f0 = (s.get("faults") or [{}])[0]
        fig["kind"], fig["magnitude"] = f0.get("kind"), f0.get("magnitude")
        fig["detected"] = det_s is not None
        fig["latency_s"] = None if det_s is None else det_s - f0.get("injected_at_s")
        must = fig["kind"] == "stuck" or abs(fig["magnitude"] or 0.0) >= MAG_MUST_DETECT_T
        kept = fig["final_mode"] == "hold" and (fig["final_error_deg"] or math.inf) < HOLD_DEG
        return (fig["detected"] or not must) and kept and not bad, fig
    if cls in ("undetected", "gnss"):
        return outcome_undetected(s, fig, det_s, bad, rate)
    if cls == "wheel":
        fig["ape_deg"] = s.get("ape_after_settle_deg")
        fig["final_error_deg"] = s.get("final_error_deg")
        f0 = (s.get("faults") or [{}])[0]
        fig["kind"], fig["magnitude"] = f0.get("kind"), f0.get("magnitude")
        fig["detected"] = det_s is not None
        fig["latency_s"] = None if det_s is None else det_s - f0.get("injected_at_s")
        fig["run_status"] = s.get("run_status")
        # a tachometer only a little noisier may stay under the floor (the wheel works)
        must = not may_miss(fig)
        # the hold itself: the campaign's own requirements judge it
        return (fig["detected"] or not must) and not bad, fig
    return not bad, fig


def twins(nominal_dir):
    """The fault-free twin's summary of each run, by run name (empty without a directory)."""
    if not nominal_dir:
        return {}
    return {os.path.basename(os.path.dirname(p)): s for p, _, s in load(nominal_dir)}


def add_twin(fig, tw):
    """The fault-free twin's figures beside the run's (tw: its summary, or {})."""
    fig["nominal_propellant_kg"] = tw.get("propellant_kg")
    fig["nominal_final_error_deg"] = tw.get("final_error_deg")
    fig["nominal_ape_deg"] = ((tw.get("pointing") or {}).get("ape_deg") or {}).get("total")
    fig["nominal_settle_time_s"] = tw.get("settle_time_s")


def analyse(dirname, cls, sim_host=None, nominal_dir=None):
    runs = load(dirname)
    twin = twins(nominal_dir)
    if not runs:
        print(f"no runs/*/result.json under {dirname}", file=sys.stderr)
        return 1
    n = len(runs)
    errored, detected, wrong, false_alarms, events, failed_outcome = [], 0, [], 0, 0, []
    latency, isolated, onset_mode, figs, iso_kind = [], {}, {}, [], {}
    for path, status, s in runs:
        run = os.path.basename(os.path.dirname(path))
        verdict_is_outcome = cls in ("undetected", "gnss")  # a lost-control verdict is what it measures
        # the campaign's record carries the lost-control verdict as its status too
        flew = status in ("ok", "requirement_failed") or (
            verdict_is_outcome
            and status in ("control_lost", "recovery_failed", "pointing_degraded", "propellant_exceeded")
        )
        if not flew or (s.get("run_status") != "ok" and not verdict_is_outcome):
            errored.append(f"{run}:{status}/{s.get('run_status')}")
        fd = s.get("fdir") or {}
        false_alarms += fd.get("false_alarms", 0)
        evs = fd.get("events") or []
        events += len(evs)
        faults = s.get("faults") or []
        det_s = None
        if faults:
            f0 = faults[0]
            count(onset_mode, mode_at(s, f0["injected_at_s"] if f0.get("injected_at_s") is not None else f0["onset_s"]))
            det_s = f0.get("detected_at_s")
            if det_s is not None and f0.get("injected_at_s") is not None:
                detected += 1
                latency.append(det_s - f0["injected_at_s"])
            for e in evs:
                if e.get("fault") == 0:
                    count(isolated, e.get("isolated_as"))
                    kind = "injected" if e.get("isolated_as") == f0["unit"] else e.get("isolated_as")
                    count(iso_kind, kind if kind in ("injected", "ambiguous") else "other")
                    # a wheel's isolation names the part (rotor, tachometer, ambiguous), a
                    # sensor's the unit: either way the event's unit must be the fault's
                    named = e.get("isolated_as") in (f0["unit"], "ambiguous", "rotor", "tachometer")
                    # a bias step the monitor cannot place on one axis names the gyro
                    unit_ok = e.get("unit") == f0["unit"] or (
                        cls == "gyro-bias-step" and e.get("unit") == "gyro" and e.get("isolated_as") == "ambiguous"
                    ) or (cls == "magnetometer" and e.get("unit") == "magnetometer" and e.get("isolated_as") == "ambiguous")
                    if not unit_ok or not named:
                        wrong.append(f"{run}:{e.get('unit')}/{e.get('isolated_as')}!={f0['unit']}")
        refly = None
        if sim_host and faults and faults[0].get("injected_at_s") is not None:
            t0 = faults[0]["injected_at_s"]
            col = "error_deg" if cls == "gyro-bias-step" else "est_error_deg"
            refly = lambda p=path, t0=t0, c=col: post_onset_est_max(sim_host, p, t0, c)  # noqa: E731
        bad_run = bool(evs) if cls == "nominal" else fd.get("false_alarms", 0) > 0
        ok, fig = outcome(cls, s, det_s, bad_run, refly)
        fig["run"] = run
        fig["isolated_as"] = [e.get("isolated_as") for e in evs if e.get("fault") == 0]
        if nominal_dir:
            add_twin(fig, twin.get(run) or {})
        figs.append(fig)
        if not ok:
            failed_outcome.append(run)
    print(f"campaign: {dirname}  class: {cls}  runs: {n}")
    if cls != "nominal":
        print(f"detected: {detected} / {n}  P_D >= {cp_lower(detected, n):.5f} (95 % one-sided Clopper-Pearson)")
        print(f"latency from the first step in force (s), median / p95 / max: {spread(latency)}")
        print(f"isolated as: {isolated}  wrong unit: {len(wrong)} {wrong[:10]}")
        print(f"isolated as the injected unit / ambiguous / other: {iso_kind}")
        print(f"mode at the onset: {onset_mode}")
    print(f"false alarms: {false_alarms}  FDIR events: {events}  errored runs: {len(errored)} {errored[:10]}")
    if cls == "nominal":
        days = sum(s.get("sim_time_s") or 0.0 for _, _, s in runs) / 86400.0
        bound = f"<= {-math.log(ALPHA) / days:.4f} per day (95 %, Poisson)" if events == 0 else ""
        print(f"flown: {days:.2f} days  {bound}")
    report_outcome(cls, figs)
    if nominal_dir:
        print(f"fault-free twins: {len(twin)} runs in {nominal_dir}, {sum(1 for f in figs if f['run'] not in twin)} runs without one")
    print(f"outcome failed: {len(failed_outcome)} {failed_outcome[:20]}")
    # a bias step below BIAS_MUST_DETECT_RAD_S may be missed: its outcome judges it
    missed = cls not in ("nominal", "gyro-bias-step", "magnetometer", "wheel", "undetected") and detected < n
    bad = errored or missed or wrong or false_alarms or failed_outcome
    return 1 if bad else 0


def report_outcome(cls, figs):
    modes = {}
    for f in figs:
        count(modes, f["final_mode"])
    print(f"final mode: {modes}")
    rates = [math.degrees(f["final_rate_rad_s"]) for f in figs if math.isfinite(f["final_rate_rad_s"])]
    print(f"final |w| (deg/s), median / p95 / max: {spread(rates, '{:.4f}')}")
    if cls == "tracker":
        est = [f["est_max_deg"] for f in figs if f["est_max_deg"] is not None]
        print(f"estimate's max error over the run (deg), median / p95 / max: {spread(est, '{:.3f}')}")
        re = [(f["run"], f["est_post_onset_max_deg"]) for f in figs if "est_post_onset_max_deg" in f]
        print(f"over {EST_MAX_DEG} deg, re-flown, max error from the onset on (deg): {re}")
        hold = [f["final_error_deg"] for f in figs if f["final_mode"] == "hold"]
        print(f"runs ending in hold: {len(hold)}, final error (deg) median / p95 / max: {spread(hold, '{:.4f}')}")
    if cls in ("gyro", "tracker"):
        safe = [f["to_safe_s"] for f in figs if f["to_safe_s"] is not None]
        print(f"detection -> sun-safe (s), {len(safe)} runs, median / p95 / max: {spread(safe)}")
    if cls == "gyro-bias-step":
        report_bias_step(figs)
    if cls == "magnetometer":
        report_magnetometer(figs)
    if cls in ("undetected", "gnss"):
        report_undetected(figs)
        if any(f["final_mode"] is None for f in figs):
            report_no_mode(figs)
    if cls == "wheel":
        report_wheel(figs)
    if cls in ("wheel", "nominal"):
        print_spread(figs, "ape_deg", "APE after settle (deg)", "{:.5f}")
        print_spread(figs, "final_error_deg", "final error (deg)", "{:.5f}")


def print_spread(figs, key, label, fmt):
    """`label, median / p95 / max: ...` of the runs' `key`, if any has it."""
    xs = [f[key] for f in figs if f.get(key) is not None]
    if xs:
        print(f"{label}, median / p95 / max: {spread(xs, fmt)}")


def decade(m):
    """The magnitude's decade [10^e, 10^(e+1)) as its lower end."""
    return 10.0 ** math.floor(math.log10(abs(m)) + 1e-9)


def held(fig):
    """A run whose step came in hold with its pointing error after the onset measured."""
    return fig["err_post_onset_max_deg"] is not None and fig["mode_at_onset"] == "hold"


def report_bias_step(figs):
    by_mag, by_dec = {}, {}
    for f in figs:
        by_mag.setdefault(abs(f["magnitude"]), []).append(f)
        by_dec.setdefault(decade(f["magnitude"]), []).append(f)
    for label, groups in (("|step|", by_mag), ("decade", by_dec)):
        for key in sorted(groups):
            fs = groups[key]
            det = [f for f in fs if f["detected"]]
            lat = [f["latency_s"] for f in det]
            # an onset in a slew measures the slew's own error: the hold's only here
            err = [f["err_post_onset_max_deg"] for f in fs if held(f)]
            fin = [f["final_error_deg"] for f in fs if f["final_error_deg"] is not None]
            print(
                f"{label} {key:.0e} rad/s: detected {len(det)} / {len(fs)}"
                f" (P_D >= {cp_lower(len(det), len(fs)):.4f}); latency (s) median / p95 / max: {spread(lat)};"
                f" max error after an onset in hold (deg) {spread(err, '{:.4f}')}; final error (deg) {spread(fin, '{:.4f}')}"
            )
    onset = {}
    for f in figs:
        count(onset, f["mode_at_onset"])
    print(f"mode at the onset: {onset}")
    missed = [f for f in figs if not f["detected"]]
    print(f"missed: {len(missed)}")
    for f in missed:
        err = f["err_post_onset_max_deg"]
        err = "-" if err is None else f"{err:.4f}"
        print(
            f"  run {f['run']}: step {f['magnitude']:+.0e} rad/s, max error after the onset {err} deg,"
            f" final {f['final_error_deg']:.4f} deg in {f['final_mode']}, estimator resets {f['estimator_resets']}"
        )
    for f in figs:
        if f["mode_at_onset"] != "hold":
            print(
                f"  onset in {f['mode_at_onset']}: run {f['run']}, step {f['magnitude']:+.0e} rad/s,"
                f" detected {f['detected']}, ends in {f['final_mode']} {f['final_error_deg']:.4f} deg"
            )
    err = [f["err_post_onset_max_deg"] for f in figs if held(f)]
    print(f"max error after an onset in hold (deg), median / p95 / max: {spread(err, '{:.4f}')}")
    fin = [f["final_error_deg"] for f in figs if f["final_error_deg"] is not None]
    print(f"final error, all runs (deg), median / p95 / max: {spread(fin, '{:.4f}')}")


def may_miss(fig):
    """A wheel fault the monitor may miss by design: a slightly noisier tachometer, a
    friction the speed loop absorbs (the constants above)."""
    mag = abs(fig.get("magnitude") or 0.0)
    return (fig["kind"] == "tach_noise" and mag < TACH_NOISE_MUST_DETECT) or (
        fig["kind"] == "friction" and mag < FRICTION_MUST_DETECT
    )


def report_wheel(figs):
    """Per fault magnitude (a kind with one, e.g. tach_noise): detection, latency, isolation."""
    groups = {}
    for f in figs:
        if f.get("magnitude") is not None:
            groups.setdefault((f["kind"], abs(f["magnitude"])), []).append(f)
    for (kind, mag) in sorted(groups):
        flown = groups[(kind, mag)]
        # a run that stopped (diverged, errored; counted above) did not fly its fault
        fs = [f for f in flown if f["run_status"] == "ok"]
        det = [f for f in fs if f["detected"]]
        lat = [f["latency_s"] for f in det]
        ape = [f["ape_deg"] for f in fs if f.get("ape_deg") is not None]
        iso = {}
        for f in fs:
            for i in f["isolated_as"]:
                count(iso, i)
        print(
            f"{kind} {mag:g}: {len(flown) - len(fs)} stopped; detected {len(det)} / {len(fs)} (P_D >= {cp_lower(len(det), len(fs)):.4f});"
            f" latency (s) median / p95 / max: {spread(lat)}; isolated as {iso};"
            f" APE after settle (deg) {spread(ape, '{:.5f}')}"
        )
    # a small tachometer noise or friction factor may be missed: counted above
    for f in figs:
        if not f["detected"] and not may_miss(f) and f["run_status"] == "ok":
            print(f"  missed: run {f['run']}, {f['kind']} {f['magnitude']}")


def report_magnetometer(figs):
    groups = {}
    for f in figs:
        key = "stuck" if f["kind"] == "stuck" else f"{abs(f['magnitude']):.0e} T"
        groups.setdefault(key, []).append(f)
    for key in sorted(groups):
        fs = groups[key]
        det = [f for f in fs if f["detected"]]
        lat = [f["latency_s"] for f in det]
        fin = [f["final_error_deg"] for f in fs if f["final_error_deg"] is not None]
        print(
            f"{key}: detected {len(det)} / {len(fs)} (P_D >= {cp_lower(len(det), len(fs)):.4f});"
            f" latency (s) median / p95 / max: {spread(lat)}; final error (deg) {spread(fin, '{:.4f}')}"
        )
    for f in figs:
        if not f["detected"]:
            print(f"  missed: run {f['run']}, {f['kind']} {f['magnitude']}, ends {f['final_mode']} {f['final_error_deg']:.4f} deg")


def report_undetected(figs):
    groups = {}
    for f in figs:
        mag = f["magnitude"]
        if not mag:  # a kind without a magnitude (or 0)
            key = f"{f['kind']}" if mag is None else f"{f['kind']} 0"
        else:
            key = f"{f['kind']} {'-' if mag < 0 else '+'}{decade(mag):.0e}"
        groups.setdefault(key, []).append(f)
    for key in sorted(groups):
        fs = groups[key]
        verdicts, modes = {}, {}
        for f in fs:
            count(verdicts, f["verdict"])
            count(modes, f["final_mode"])
        det = sum(1 for f in fs if f["detected"])
        fin = [f["final_error_deg"] for f in fs if f["final_error_deg"] is not None and f["final_mode"] == "hold"]
        print(
            f"{key}: {len(fs)} runs, detected {det}; verdicts {verdicts}; final mode {modes};"
            f" final error in hold (deg) median / p95 / max: {spread(fin, '{:.4f}')}"
        )
    onset = {}
    for f in figs:
        count(onset, f["mode_at_onset"])
    print(f"mode at the onset: {onset}")


def verdict_counts(fs):
    """ok / control_lost / recovery_failed / pointing_degraded / propellant_exceeded / other (any
    other run_status)."""
    out = {"ok": 0, "control_lost": 0, "recovery_failed": 0, "pointing_degraded": 0, "propellant_exceeded": 0, "other": 0}
    for f in fs:
        count(out, f["verdict"] if f["verdict"] in out else "other")
    return out


def no_mode_row(label, fs):
    """One group of runs without a mode manager: verdicts, final error, ok runs off the bound."""
    fin = [f["final_error_deg"] for f in fs if f["final_error_deg"] is not None]
    off = [f for f in fs if f["verdict"] == "ok" and f["off"]]
    ape = [f["ape_deg"] for f in fs if f.get("ape_deg") is not None]
    settled = [f["settle_time_s"] for f in fs if f.get("settle_time_s") is not None]
    # reported, not judged: an ok run whose end window's APE passes the bound
    ape_off = [f for f in fs if f["verdict"] == "ok" and f.get("ape_deg") is not None and not f["ape_deg"] < f["bound_deg"]]
    print(
        f"  {label}: {len(fs)} runs; verdicts {verdict_counts(fs)}; final error (deg) median / p95 / max:"
        f" {spread(fin, '{:.3g}')}; ok but off (> bound): {len(off)};"
        f" APE 95 % of the end window (deg) {spread(ape, '{:.3g}')}, ok with it > bound: {len(ape_off)};"
        f" within the bound to the end from (s) {spread(settled, '{:.1f}')}, never: {len(fs) - len(settled)}"
    )


def report_no_mode(figs):
    """The runs without a mode manager (judged on final_error_deg against their settle bound):
    per magnitude decade and per unit, the silent degradations, the propellant."""
    figs = [f for f in figs if f["final_mode"] is None]
    bounds = sorted({f["bound_deg"] for f in figs})
    froms = sorted({f["ape_from_s"] for f in figs if f.get("ape_from_s") is not None})
    print(f"without a mode manager: {len(figs)} runs, judged on the final error against {bounds} deg; end window from {froms} s")
    by_mag, by_unit = {}, {}
    for f in figs:
        mag = f["magnitude"]
        by_mag.setdefault("-" if not mag else f"{decade(mag):.0e}", []).append(f)
        by_unit.setdefault(f["unit"], []).append(f)
    print(" per magnitude decade:")
    for key in sorted(by_mag, key=lambda k: -1.0 if k == "-" else float(k)):
        no_mode_row(key, by_mag[key])
    print(" per unit:")
    for key in sorted(by_unit, key=str):
        no_mode_row(key, by_unit[key])
    no_mode_row("all", figs)
    off = sorted((f for f in figs if f["verdict"] == "ok" and f["off"]), key=lambda f: -(f["final_error_deg"] or math.inf))
    for f in off[:10]:
        print(f"  ok but off: run {f['run']} {f['unit']} {f['kind']} {f['magnitude']}: {f['final_error_deg']:.3f} deg")
    print_spread(figs, "nominal_final_error_deg", " fault-free twins' final error (deg)", "{:.3g}")
    tw = [f["nominal_ape_deg"] for f in figs if f.get("nominal_ape_deg") is not None]
    if tw:
        print_spread(figs, "nominal_ape_deg", " fault-free twins' APE 95 % of the end window (deg)", "{:.3g}")
        tw = [f["nominal_settle_time_s"] for f in figs if f.get("nominal_settle_time_s") is not None]
        print(f" fault-free twins within the bound to the end from (s), median / p95 / max: {spread(tw, '{:.1f}')}, never: {len(figs) - len(tw)}")
    report_propellant(figs)


def report_propellant(figs):
    """Thrusters: the propellant used, and against each run's fault-free twin."""
    prop = [f["propellant_kg"] for f in figs if f.get("propellant_kg") is not None]
    if not prop:
        return
    print(f" propellant (kg), median / p95 / max: {spread(prop, '{:.4g}')}")
    budgets = sorted({f["budget_kg"] for f in figs if f.get("budget_kg") is not None})
    if budgets:
        over = [f for f in figs if f.get("over_budget")]
        print(f" above the budget {budgets} kg: {len(over)} runs; their verdicts {verdict_counts(over)}")
    nom = [f["nominal_propellant_kg"] for f in figs if f.get("nominal_propellant_kg") is not None]
    if nom:
        print(f" fault-free twins' propellant (kg), median / p95 / max: {spread(nom, '{:.4g}')}")
        ratio = [
            f["propellant_kg"] / f["nominal_propellant_kg"]
            for f in figs
            if f.get("propellant_kg") is not None and (f.get("nominal_propellant_kg") or 0.0) > 0.0
        ]
        print(f" propellant / its twin's, median / p95 / max (min {min(ratio):.3g}): {spread(ratio, '{:.3g}')}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir", nargs="?")
    ap.add_argument("--class", dest="cls", choices=["tracker", "gyro", "gyro-bias-step", "magnetometer", "wheel", "gnss", "undetected", "nominal"])
    ap.add_argument("--self-test", action="store_true")
    ap.add_argument("--refly", metavar="SIM_HOST", help="re-fly tracker runs over the bound, every gyro-bias-step run (CSV)")
    ap.add_argument("--nominal", metavar="NOMINAL_DIR", help="undetected: the fault-free twin campaign (propellant, final error)")
    a = ap.parse_args()
    if a.self_test:
        return self_test()
    if not a.dir or not a.cls:
        ap.error("DIR and --class are needed (or --self-test)")
    return analyse(a.dir, a.cls, a.refly, a.nominal)


if __name__ == "__main__":
    sys.exit(main())
