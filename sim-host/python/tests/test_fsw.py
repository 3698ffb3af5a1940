"""acs.Fsw: the flight step from Python gives the in-process link's command bits for a
recorded frame sequence; bad frames raise acs.FrameError; a property test on random frames."""

import math
import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import acs
from conftest import REPO


def f32_bits(x):
    return struct.pack("<f", x)


def cmd_bits(cmd):
    """Every number of the command as bytes (f32 as its 4 bytes: bit for bit)."""
    out = []

    def walk(v):
        if isinstance(v, dict):
            for k in sorted(v):
                walk(v[k])
        elif isinstance(v, (list, tuple)):
            for x in v:
                walk(x)
        elif isinstance(v, float):
            out.append(f32_bits(v))
        else:
            out.append(repr(v).encode())

    walk(cmd)
    return b"".join(out)


@pytest.mark.parametrize(
    "name,steps",
    [("paper000/test1.toml", None), ("paper004/dp-nominal.toml", 500), ("modes/cubesat-mission.toml", None)],
)
def test_fsw_step_gives_the_in_process_command_bits(name, steps):
    sc = acs.Scenario.load(REPO / "scenarios" / name)
    recorded = acs.record_frames(sc, steps=steps)
    assert len(recorded) == (steps if steps else sc.steps + 1)
    fsw = acs.Fsw(sc)
    sent = 0
    for i, rec in enumerate(recorded):
        for msg in rec["requests"]:  # ground commands, as the run sent them
            fsw.request(msg)
            sent += 1
        frame = rec["frame"] if i % 2 else acs.frame_to_bytes(rec["frame"])  # dict and postcard bytes
        reply = fsw.step(frame)
        assert cmd_bits(reply["cmd"]) == cmd_bits(rec["reply"]["cmd"]), f"{name}: step {i}"
    if name.startswith("modes/"):
        assert sent > 0  # the mission's ground commands were replayed


def test_open_loop_scenarios_have_no_flight_software():
    with pytest.raises(acs.ScenarioError, match="open loop"):
        acs.Fsw(acs.Scenario.load(REPO / "scenarios/paper003/rig-open-loop.toml"))


@pytest.fixture(scope="module")
def scenario():
    return acs.Scenario.load(REPO / "scenarios/estimation/mekf-hold.toml")


def test_bad_frames_raise_frame_error(scenario):
    fsw = acs.Fsw(scenario)
    good = acs.empty_frame(1, 0)
    for bad in [
        {**good, "seq": "one"},  # wrong type
        {k: v for k, v in good.items() if k != "valid"},  # missing field
        {**good, "q_ib_xyzw": [0.0, 0.0, 1.0]},  # wrong length
        {**good, "seq": -1},
        b"\x01\x02",  # not a postcard frame
        [1, 2, 3],
    ]:
        with pytest.raises(acs.FrameError):
            fsw.step(bad)
    fsw.step(good)
    with pytest.raises(acs.FrameError, match="refused"):
        fsw.step(good)  # the same seq again: one frame, one step
    with pytest.raises(acs.FrameError):
        fsw.request({"NoSuchMessage": 1})


FLOATS = st.one_of(
    st.floats(width=32, allow_nan=True, allow_infinity=True),
    st.floats(min_value=-10.0, max_value=10.0, width=32),
)
VECTOR_FIELDS = ["q_ib_xyzw", "rate_rad_s", "gyro_angle_rad", "mag_field_t", "sun_dir", "gnss_pos_m", "gnss_vel_m_s"]


@st.composite
def frames(draw, seq):
    f = acs.empty_frame(seq, seq * 100_000)
    for k in VECTOR_FIELDS:
        f[k] = [draw(FLOATS) for _ in f[k]]
    f["css_output"] = [draw(FLOATS) for _ in f["css_output"]]
    f["valid"] = draw(st.integers(0, 0xFFFF))
    f["gyro_interval_us"] = draw(st.integers(0, 2**32 - 1))
    f["gnss_j2000_s"] = draw(FLOATS)
    f["gnss_j2000_days"] = draw(st.integers(-(2**31), 2**31 - 1))
    return f


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_any_frame_gives_a_finite_command_or_frame_error(scenario, data):
    fsw = acs.Fsw(scenario)
    for seq in range(1, 6):
        try:
            reply = fsw.step(data.draw(frames(seq)))
        except acs.FrameError:
            continue
        cmd = reply["cmd"]
        for k in ("wheel_torque_cmd_nm", "dipole_cmd_am2", "gimbal_rate_cmd_rad_s", "thruster_level", "torque_demand_nm"):
            assert all(math.isfinite(x) for x in cmd[k]), (k, cmd[k])
