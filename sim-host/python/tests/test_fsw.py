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


# ---- issue 37: message fields read as strictly as the wire reads bytes --------------------

DMCS = REPO / "scenarios/paper001/dmcs-m1.toml"


@pytest.mark.parametrize(
    "msg,field",
    [
        ({"FreezeAdaptation": {"frozen": "false"}}, "`FreezeAdaptation.frozen`: expected a bool"),
        ({"FreezeAdaptation": {"frozen": 0}}, "`FreezeAdaptation.frozen`: expected a bool"),
        ({"FreezeAdaptation": {"frozen": None}}, "`FreezeAdaptation.frozen`: expected a bool"),
        ({"FreezeAdaptation": {"frozen": False, "also": 1}}, "unknown field `also` of FreezeAdaptation"),
        ({"FreezeAdaptation": {}}, "missing field `frozen`"),
        ({"SetTarget": {"target_q_xyzw": [0, 0, True, 1]}}, "`SetTarget.target_q_xyzw[2]`: expected a number"),
        ({"SetTarget": {"target_q_xyzw": [0, 0, "0", 1]}}, "`SetTarget.target_q_xyzw[2]`: expected a number"),
        ({"SetTarget": {"target_q_xyzw": [0, 0, 1e39, 1]}}, "`SetTarget.target_q_xyzw[2]`: 1e39 is beyond the f32"),
        ({"SetTarget": {"target_q_xyzw": [0, 0, 1]}}, "`SetTarget.target_q_xyzw`: expected 4 values, got 3"),
        ({"Hello": {"protocol_version": 2**16, "schema_hash": 0}}, "`Hello.protocol_version`: 65536 is out of range"),
        ({"Hello": {"protocol_version": -1, "schema_hash": 0}}, "`Hello.protocol_version`: -1 is out of range"),
        ({"Hello": {"protocol_version": 14.0, "schema_hash": 0}}, "`Hello.protocol_version`: expected an integer"),
        ({"Hello": {"protocol_version": 14, "schema_hash": True}}, "`Hello.schema_hash`: expected an integer"),
        ({"CommandMode": {"Enter": "hover"}}, "unknown variant `hover` of Mode"),
        ({"CommandMode": "Auto", "StartRealTime": None}, "one key"),
        ({"NoSuchMessage": 1}, "unknown variant `NoSuchMessage` of HostMsg"),
        ({"StartRealTime": 1}, "`StartRealTime` takes no value"),
        ("SetTarget", "`SetTarget` needs a value"),
        (42, "expected a HostMsg"),
    ],
)
def test_message_fields_are_typed_and_refusals_name_the_field(msg, field):
    fsw = acs.Fsw(acs.Scenario.load(DMCS))
    with pytest.raises(acs.FrameError) as e:
        fsw.request(msg)
    assert field in str(e.value)


def test_a_refused_freeze_changes_nothing_and_a_real_one_does():
    """`{"FreezeAdaptation": {"frozen": "false"}}` was taken by truthiness (Ack, adaptation
    frozen). Now refused, and the flight software is left as it was: the replayed
    commands stay bit-identical to the in-process run's. The comparison can fail: a real
    freeze at the same step changes the commands of this adaptive (DMCS) law."""
    sc = acs.Scenario.load(DMCS)
    recorded = acs.record_frames(sc, steps=400)
    base = [cmd_bits(r["reply"]["cmd"]) for r in recorded]

    def replay(msg, refused):
        fsw = acs.Fsw(sc)
        out = []
        for i, rec in enumerate(recorded):
            if i == 100:
                if refused:
                    with pytest.raises(acs.FrameError, match="FreezeAdaptation.frozen"):
                        fsw.request(msg)
                else:
                    assert fsw.request(msg) == "Ack"
            out.append(cmd_bits(fsw.step(rec["frame"])["cmd"]))
        return out

    for bad in ("false", "", 0, 1, 0.0, None, [False], {"x": False}):
        assert replay({"FreezeAdaptation": {"frozen": bad}}, refused=True) == base, bad
    assert replay({"FreezeAdaptation": {"frozen": False}}, refused=False) == base  # resume: already adapting
    frozen = replay({"FreezeAdaptation": {"frozen": True}}, refused=False)
    assert frozen[:100] == base[:100] and frozen[100:] != base[100:]


@pytest.mark.parametrize(
    "change,field",
    [
        ({"bogus": 1}, "unknown field `bogus` of SensorFrame"),
        ({"valid": True}, "`valid`: expected an integer (not a bool)"),
        ({"valid": 0x10000}, "`valid`: 65536 is out of range for u16"),
        ({"seq": 1.0}, "`seq`: expected an integer, got float"),
        ({"seq": 2**32}, "`seq`: 4294967296 is out of range for u32"),
        ({"gnss_j2000_days": -(2**31) - 1}, "`gnss_j2000_days`: -2147483649 is out of range for i32"),
        ({"gyro_interval_us": float("nan")}, "`gyro_interval_us`: expected an integer"),
        ({"rate_rad_s": [0.0, 0.0, 3.5e38]}, "`rate_rad_s[2]`: 3.5e38 is beyond the f32 range"),
        ({"rate_rad_s": [0.0, False, 0.0]}, "`rate_rad_s[1]`: expected a number (not a bool)"),
        ({"rate_rad_s": [0.0, 0.0, 0.0, 0.0]}, "`rate_rad_s`: expected 3 values, got 4"),
        ({"rate_rad_s": "0,0,0"}, "`rate_rad_s`: expected a list"),
        ({"sampled_at": {"gyro_us": 0}}, "missing field"),
        ({"sampled_at": {**acs.empty_frame(1)["sampled_at"], "lidar_us": 0}}, "unknown field `lidar_us` of SampleTimes"),
    ],
)
def test_frame_fields_are_typed_and_refusals_name_the_field(scenario, change, field):
    fsw = acs.Fsw(scenario)
    good = acs.empty_frame(1, 0)
    with pytest.raises(acs.FrameError) as e:
        fsw.step({**good, **change})
    assert field in str(e.value)
    fsw.step(good)  # the refused frame was not stepped: the same seq is still new


def test_numpy_values_and_tuples_give_the_bits_of_plain_values(scenario):
    np = pytest.importorskip("numpy")
    plain = acs.empty_frame(1, 100_000)
    plain.update(rate_rad_s=[0.01, -0.02, 0.5], valid=2, mag_field_t=[1e-5, 2e-5, 3e-5])
    typed = dict(plain)
    typed.update(
        rate_rad_s=np.array([0.01, -0.02, 0.5], dtype=np.float32),
        valid=np.uint16(2),
        mag_field_t=tuple(np.float64(x) for x in plain["mag_field_t"]),
        seq=np.int64(1),
    )
    a, b = acs.Fsw(scenario).step(plain), acs.Fsw(scenario).step(typed)
    assert cmd_bits(a) == cmd_bits(b)
    assert acs.frame_to_bytes(plain) == acs.frame_to_bytes(typed)
    with pytest.raises(acs.FrameError, match="expected a bool"):
        acs.Fsw(acs.Scenario.load(DMCS)).request({"FreezeAdaptation": {"frozen": np.float64(0.0)}})
    assert acs.Fsw(acs.Scenario.load(DMCS)).request({"FreezeAdaptation": {"frozen": np.bool_(True)}}) == "Ack"


def test_non_finite_values_given_as_such_are_carried_as_the_wire_carries_them(scenario):
    """NaN and infinities are f32 values the wire carries: the flight code judges them
    (here: the attitude is refused as bad input, the command stays finite)."""
    for x in (float("nan"), float("inf"), -float("inf")):
        f = acs.empty_frame(1, 0)
        f.update(q_ib_xyzw=[x, 0.0, 0.0, 1.0], valid=1)
        assert acs.frame_to_bytes(f)  # encodes
        reply = acs.Fsw(scenario).step(f)
        assert all(math.isfinite(v) for v in reply["cmd"]["wheel_torque_cmd_nm"])


def test_frame_bytes_with_anything_after_the_frame_are_refused_as_on_the_wire(scenario):
    """shared/src/link/framing.rs refuses a CRC-valid frame whose payload has bytes after
    the message (FrameError::Decode; its test crc_valid_frame_with_trailing_junk_is_refused
    _and_counted); Fsw.step and frame_to_bytes refuse the same postcard bytes."""
    fsw = acs.Fsw(scenario)
    b = acs.frame_to_bytes(acs.empty_frame(1, 0))
    for bad, why in ((b + b"\x00", "1 bytes after the frame"), (b + b"\x01\x02", "2 bytes after the frame"),
                     (b[:-1], "postcard SensorFrame")):
        with pytest.raises(acs.FrameError, match=why):
            fsw.step(bad)
        with pytest.raises(acs.FrameError, match=why):
            acs.frame_to_bytes(bad)
    reply = fsw.step(bytearray(b))  # exactly one frame: stepped (the refused ones were not)
    assert reply["cmd"]["seq"] == 1


def test_empty_frame_reads_its_fields_as_a_frame_does():
    assert acs.empty_frame(3, 7)["seq"] == 3
    for seq, why in ((True, "not a bool"), (-1, "out of range"), (1.5, "expected an integer")):
        with pytest.raises(acs.FrameError, match=why):
            acs.empty_frame(seq)
