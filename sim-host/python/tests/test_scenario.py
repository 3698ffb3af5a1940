"""acs.Scenario: the campaigns' key paths, round trips, and clear errors for bad input."""

import copy
import math

import pytest

import acs
from conftest import REPO

TEST1 = REPO / "scenarios/paper000/test1.toml"


@pytest.fixture
def sc():
    return acs.Scenario.load(TEST1)


def test_get_and_set_by_key_path(sc):
    assert sc["controller.wn_rad_s"] == 0.7
    assert sc["controller.type"] == "quaternion_feedback"
    sc["controller.wn_rad_s"] = 0.8
    assert sc["controller.wn_rad_s"] == 0.8
    sc["initial.euler_deg[2]"] = 12.5
    assert sc["initial.euler_deg"][2] == 12.5
    sc["spacecraft.inertia_kgm2[2][2]"] = sc["spacecraft.inertia_kgm2[2][2]"] * 1.01
    # an int where the format has a float is stored as the float
    sc["duration_s"] = 3
    assert sc["duration_s"] == 3.0 and isinstance(sc["duration_s"], float)
    assert "controller.wn_rad_s" in sc and "controller.nope" not in sc


def test_round_trips(sc):
    sc["controller.zeta"] = 0.55
    assert acs.Scenario.from_dict(sc.to_dict()) == sc
    assert acs.Scenario.from_toml(sc.to_toml()) == sc
    assert acs.Scenario.from_toml(sc.to_toml()).to_toml() == sc.to_toml()
    c = copy.deepcopy(sc)
    c["controller.zeta"] = 0.6
    assert sc["controller.zeta"] == 0.55 and c != sc


def test_a_set_key_is_what_the_run_flies(sc):
    """Setting a key changes the run exactly as editing the file does."""
    sc["duration_s"] = 2.0
    text = sc.to_toml().replace("wn_rad_s = 0.7", "wn_rad_s = 0.9")
    assert "wn_rad_s = 0.9" in text
    sc["controller.wn_rad_s"] = 0.9
    a = acs.run(sc)
    b = acs.run(acs.Scenario.from_toml(text))
    assert a.summary["final_error_deg"] == b.summary["final_error_deg"]


def test_update_sets_several_keys_checked_together(sc):
    with pytest.raises(acs.ScenarioError):
        sc["controller.type"] = "rate_damping"  # alone: the quaternion-feedback keys remain
    d = sc.to_dict()["controller"]
    sc.update({"controller": {"type": "quaternion_feedback", **{k: v for k, v in d.items() if k != "type"}}, "duration_s": 4.0})
    assert sc["duration_s"] == 4.0


@pytest.mark.parametrize(
    "key,value,names",
    [
        ("controller.nope", 1.0, "nope"),  # unknown key
        ("duration_s", "ten", "duration_s"),  # wrong type
        ("duration_s", math.nan, "duration_s"),  # NaN
        ("duration_s", math.inf, "duration_s"),
        ("initial.euler_deg", [1.0, math.nan, 0.0], "initial.euler_deg[1]"),
        ("duration_s", -1.0, "duration_s"),  # out of range
        ("duration_s", None, "duration_s"),  # TOML has no null
        ("initial.euler_deg", [1.0, 2.0], "euler_deg"),  # wrong length
        ("controller.wn_rad_s", {"a": 1}, "wn_rad_s"),
    ],
)
def test_bad_values_raise_scenario_error_naming_the_key(sc, key, value, names):
    before = sc.to_toml()
    with pytest.raises(acs.ScenarioError) as e:
        sc[key] = value
    assert names in str(e.value)
    assert sc.to_toml() == before  # a refused change leaves the scenario as it was


def test_bad_paths(sc):
    with pytest.raises(KeyError, match="nope"):
        sc["nope.x"]
    with pytest.raises(KeyError, match="out of range"):
        sc["initial.euler_deg[3]"]
    with pytest.raises(acs.ScenarioError, match="key path"):
        sc["a..b"]
    with pytest.raises(acs.ScenarioError):
        sc["initial.euler_deg[5]"] = 1.0


def test_bad_files_and_dicts():
    with pytest.raises(acs.ScenarioError, match="no-such-file"):
        acs.Scenario.load(REPO / "no-such-file.toml")
    with pytest.raises(acs.ScenarioError):
        acs.Scenario.from_toml("name = 1")
    with pytest.raises(TypeError):
        acs.Scenario.from_dict([1, 2])
    d = acs.Scenario.load(TEST1).to_dict()
    d["spacecraft"]["bogus"] = 1.0
    with pytest.raises(acs.ScenarioError, match="bogus"):
        acs.Scenario.from_dict(d)


def test_check_resolves_like_sim_host_check(sc):
    info = sc.check()
    assert info["name"] == "paper000-test1" and info["closed_loop"] and info["steps"] == sc.steps
    assert isinstance(info["checksum"], int)
    modes = acs.Scenario.load(REPO / "scenarios/modes/cubesat-mission.toml").check()
    assert "mode_checksums" in modes and len(modes["mode_checksums"]) >= 2


def test_errors_are_acs_errors():
    for cls in (acs.ScenarioError, acs.RunError, acs.FrameError, acs.CampaignError, acs.InternalError):
        assert issubclass(cls, acs.AcsError) and issubclass(cls, Exception)
    # Issue 37: the KeyError and TypeError the scenario raises are acs errors too.
    assert issubclass(acs.ScenarioKeyError, acs.ScenarioError) and issubclass(acs.ScenarioKeyError, KeyError)
    assert issubclass(acs.ScenarioTypeError, acs.ScenarioError) and issubclass(acs.ScenarioTypeError, TypeError)
    sc = acs.Scenario.load(TEST1)
    with pytest.raises(acs.ScenarioKeyError, match="nope"):
        sc["nope"]
    with pytest.raises(acs.ScenarioTypeError, match="needs a dict"):
        acs.Scenario.from_dict([1, 2])
    with pytest.raises(acs.ScenarioError, match="key path"):
        sc.update({1: 2.0})


def test_a_rust_panic_raises_and_the_interpreter_goes_on():
    for _ in range(3):
        with pytest.raises(acs.InternalError, match="deliberate"):
            acs._core._panic_for_test("deliberate")
    assert acs.Scenario.load(TEST1).name == "paper000-test1"
