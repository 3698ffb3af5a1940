"""Issue 25, second method: python-control on the same loop as `sim-host margins` measures
(tests/scenarios/margins/rigid-pd.toml and variants), built as a continuous state space,
discretised with `control.c2d(..., "zoh")`, delays as z^-1 states (a fractional delay by two
ZOH discretisations over T - delta and delta), margins from `control.stability_margins`.

Compared with (i) the CLI's measured response and margins (1 % / 1 deg), and (ii) closed
forms written here (Franklin-Powell-Workman ZOH double integrator, the continuous-limit
crossover and phase margin of J s^2 + D s + K/2, an integer delay's -w T n phase).
Independent of the Rust reference (tests/support/src/loop_reference.rs)."""

import json
import math
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

control = pytest.importorskip("control")

REPO = Path(__file__).resolve().parents[3]
BASE = REPO / "tests/scenarios/margins/rigid-pd.toml"
J = [10.0, 12.0, 15.0]  # scenario inertia, wheels included
J_WHEEL = 0.01  # the wheels' axial inertia: the plant integrates J - J_WHEEL
K = [5.0, 6.0, 7.5]  # u = -K q_e - D w, q_e ~ theta/2
D = [7.0, 8.4, 10.5]
T = 0.1


def plant_ss(jp, lag):
    """Continuous plant from the torque input e to x = (theta, w[, a])."""
    if lag > 0:
        a = [[0, 1, 0], [0, 0, 1 / jp], [0, 0, -1 / lag]]
        b = [[0], [0], [1 / lag]]
    else:
        a = [[0, 1], [0, 0]]
        b = [[0], [1 / jp]]
    n = len(a)
    return control.ss(a, b, np.eye(n), np.zeros((n, 1)))


def open_loop(axis, delay=0.0, lag=0.0, inertia=1.0, gain=1.0, period=T):
    """L(z) at the plant input: discrete state space (python-control), controller
    [K/2, D] on (theta, w)."""
    jp = J[axis] * inertia - J_WHEEL
    sys = plant_ss(jp, lag)
    n_whole = int(math.floor(delay / period + 1e-12))
    frac = delay - n_whole * period
    frac = 0.0 if frac < 1e-12 * period else frac
    full = control.c2d(sys, period, "zoh")
    phi = np.asarray(full.A)
    if frac > 0:
        rest = control.c2d(sys, period - frac, "zoh")
        first = control.c2d(sys, frac, "zoh")
        g1 = np.asarray(rest.B)
        g0 = np.asarray(rest.A) @ np.asarray(first.B)
    else:
        g1, g0 = np.asarray(full.B), None
    nx = phi.shape[0]
    # State: plant x, then the previous input when a fractional delay needs it.
    if g0 is not None:
        a = np.block([[phi, g0], [np.zeros((1, nx)), np.zeros((1, 1))]])
        b = np.vstack([g1, [[1.0]]])
    else:
        a, b = phi, g1
    c = np.zeros((1, a.shape[0]))
    c[0, 0], c[0, 1] = 0.5 * K[axis] * gain, D[axis] * gain
    plant = control.ss(a, b, c, [[0.0]], period)
    if n_whole:
        delay_tf = control.tf([1.0], [1.0] + [0.0] * n_whole, period)  # z^-n
        plant = control.series(control.ss(delay_tf), plant)
    return plant


def response(sys, w):
    return np.asarray(control.frequency_response(sys, np.asarray(w)).complex).reshape(-1)


def margins(sys):
    """python-control's margins. Its phase crossovers below 1e-3 rad/s are dropped: the
    double integrator's phase tends to -180 deg as w -> 0 and python-control reports a
    spurious crossing there (about -171 dB at 2e-5 rad/s for the nominal loop)."""
    gm, pm, sm, wpc, wgc, wms = control.stability_margins(sys)
    gms, _, _, wpcs, _, _ = control.stability_margins(sys, returnall=True)
    inner = [20 * math.log10(g) for g, w in zip(np.atleast_1d(gms), np.atleast_1d(wpcs)) if w > 1e-3 and g > 1]
    return {"gm_db": min(inner) if inner else None, "pm": pm, "wc": wgc}


# ---- (ii) closed forms -------------------------------------------------------------------


def test_zoh_double_integrator_is_the_textbook_form():
    sys = open_loop(0)
    jp = J[0] - J_WHEEL
    w = np.array([0.05, 0.7, 3.0, 20.0])
    z = np.exp(1j * w * T)
    th = T**2 * (z + 1) / (2 * jp * (z - 1) ** 2)
    om = T / (jp * (z - 1))
    want = 0.5 * K[0] * th + D[0] * om
    np.testing.assert_allclose(response(sys, w), want, rtol=1e-9)
    # At Nyquist theta/e vanishes: L = -D T/(2 J_p), real and negative (the gain margin there;
    # python-control's stability_margins does not report it, the measurement does).
    at_nyquist = response(sys, [math.pi / T])[0]
    assert at_nyquist.real == pytest.approx(-D[0] * T / (2 * jp), rel=1e-9) and abs(at_nyquist.imag) < 1e-9


def test_continuous_limit_crossover_and_phase_margin():
    # J s^2 + D s + K/2 with K/2 = wn^2 J, D = 2 zeta wn J (J_c = J_p here).
    wn, zeta, t = 0.5, 0.7, 1e-4
    jp = J[0] - J_WHEEL
    sys = open_loop(0, period=t)
    scale = jp / (J[0] * 1.0)  # give the loop J_c = J_p
    sys = sys * (scale)
    wc = wn * math.sqrt(2 * zeta**2 + math.sqrt(4 * zeta**4 + 1))
    pm = math.degrees(math.atan(2 * zeta * wc / wn)) - math.degrees(wc * t / 2)
    m = margins(sys)
    assert m["wc"] == pytest.approx(wc, rel=1e-4)
    assert m["pm"] == pytest.approx(pm, abs=0.01)


def test_integer_delay_adds_minus_omega_t_n():
    w = np.array([0.05, 0.7, 3.0, 20.0])
    base = response(open_loop(1), w)
    for n in (1, 2, 3):
        r = response(open_loop(1, delay=n * T), w) / base
        np.testing.assert_allclose(r, np.exp(-1j * w * T * n), atol=1e-9)


# ---- (i) against the measurement --------------------------------------------------------

VARIANTS = {
    "nominal": ("", 0.0, 0.0),
    "lag": ("torque_lag_s = 0.2", 0.0, 0.2),
    "delay-whole": ("torque_delay_s = 0.1", 0.1, 0.0),
    "delay-half": ("torque_delay_s = 0.05", 0.05, 0.0),
}


@pytest.fixture(scope="module")
def measured(sim_host):
    """`sim-host margins --json` of every variant (run in parallel)."""
    tmp = Path(tempfile.mkdtemp(prefix="margins-"))
    procs = {}
    for name, (extra, _, _) in VARIANTS.items():
        text = BASE.read_text().replace("[actuators.wheels]", f"[actuators.wheels]\n{extra}")
        path = tmp / f"{name}.toml"
        path.write_text(text)
        out = tmp / name
        procs[name] = (subprocess.Popen([str(sim_host), "margins", str(path), "--json", "--out", str(out)],
                                        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE), out)
    result = {}
    for name, (p, out) in procs.items():
        _, err = p.communicate()
        assert p.returncode == 0, f"{name}: {err.decode()}"
        result[name] = json.loads((out / "margins.json").read_text())
    return result


@pytest.mark.parametrize("name", list(VARIANTS))
def test_python_control_agrees_with_the_measurement(measured, name):
    m = measured[name]
    _, delay, lag = VARIANTS[name]
    w = np.asarray(m["frequencies_rad_s"])
    for axis in range(3):
        sys = open_loop(axis, delay=delay, lag=lag)
        want = response(sys, w)
        got = np.array([complex(*f[axis][axis]) for f in m["response"]])
        ratio = got / want
        mag = np.max(np.abs(np.abs(ratio) - 1))
        ph = np.max(np.abs(np.degrees(np.angle(ratio))))
        print(f"{name} axis {axis}: worst |L| {100 * mag:.3f} %, phase {ph:.3f} deg")
        assert mag <= 0.01 and ph <= 1.0
        ref = margins(sys)
        a = m["axes"][axis]
        print(f"  python-control wc {ref['wc']:.6f} pm {ref['pm']:.4f} gm {ref['gm_db']}; "
              f"measured wc {a['crossover_rad_s']:.6f} pm {a['phase_margin_deg']:.4f} gm {a['gain_margin_high_db']}")
        assert a["crossover_rad_s"] == pytest.approx(ref["wc"], rel=0.01)
        assert a["phase_margin_deg"] == pytest.approx(ref["pm"], rel=0.01)
        assert a["delay_margin_s"] == pytest.approx(math.radians(ref["pm"]) / ref["wc"], rel=0.01)
        if a["gain_margin_high_db"] is not None and ref["gm_db"] is not None:
            assert a["gain_margin_high_db"] == pytest.approx(ref["gm_db"], rel=0.01)


def test_acs_run_measures_margins_with_the_margins_table():
    """`[margins]` in the scenario: `acs.run` measures the margins after the run into
    `summary["margins"]` (the same `sim_host::margins` as the CLI), and they agree with
    python-control's margins of the same loop (worst axis, 1 %)."""
    import acs

    sc = acs.Scenario.from_toml(BASE.read_text() + "\n[margins]\n")
    m = acs.run(sc).summary["margins"]
    assert m["status"] == "measured" and m["stable"] is True and m["method"] == "closed", m
    refs = [margins(open_loop(axis)) for axis in range(3)]
    assert m["phase_margin_deg"] == pytest.approx(min(r["pm"] for r in refs), rel=0.01)
    assert m["crossover_rad_s"] == pytest.approx(max(r["wc"] for r in refs), rel=0.01)
