"""The 3D replay from Python (docs/viewer.md): `RunResult.view` and `acs.view` write the page
`sim-host view` writes. The page's embedded channels are decoded here independently
(json, base64, struct) and compared bit for bit with the run's columns; the page of the
Python run equals the CLI's page of the same scenario channel for channel."""

import base64
import json
import re
import subprocess

import numpy as np
import pytest

import acs
from conftest import REPO, TARGET, require_tool

SCENARIO = REPO / "scenarios/modes/cubesat-mission.toml"
BUNDLE = TARGET / "viewer" / "replay-template.html"


def need_bundle(test: str) -> None:
    require_tool("viewer bundle", BUNDLE.exists(), "scripts/setup.sh (npm ci and the bundle in tools/viewer)", test)


def page_document(path) -> dict:
    """The JSON the page embeds (`globalThis.ACS_REPLAY_DATA = {...};`)."""
    text = open(path, encoding="utf-8").read()
    m = re.search(r"globalThis\.ACS_REPLAY_DATA = (\{.*?\});</script>", text, re.S)
    assert m, "no embedded data"
    return json.loads(m.group(1))


def channels(doc: dict) -> dict:
    out = {}
    for c in doc["channels"]:
        raw = base64.b64decode(c["data"])
        out[c["name"]] = np.frombuffer(raw, dtype="<f8" if c["dtype"] == "f64" else "<f4")
    return out


def short_mission(seconds: float) -> acs.Scenario:
    sc = acs.Scenario.load(SCENARIO)
    sc["duration_s"] = seconds
    return sc


def test_a_python_run_writes_the_page_of_its_columns(tmp_path):
    need_bundle("test_view::test_a_python_run_writes_the_page_of_its_columns")
    r = acs.run(short_mission(600.0))
    page = r.view(tmp_path / "replay.html")
    assert page == str(tmp_path / "replay.html")
    doc = page_document(page)
    assert doc["run_status"] == r.summary["run_status"] == "ok"
    ch = channels(doc)
    # Every row fits (600 s is far under the bound): time and quaternions bit for bit,
    # the rest as float32.
    for name in ("t_s", "q_x", "q_y", "q_z", "q_w"):
        assert np.array_equal(ch[name].view(np.uint64), r.columns[name].view(np.uint64)), name
    assert np.array_equal(ch["error_deg"], r.columns["error_deg"].astype(np.float32), equal_nan=True)
    assert {"geo_sun_eci_x", "geo_earth_radius_rad"} <= set(ch), "an orbit run carries its geometry"


def test_the_python_page_equals_the_cli_page(tmp_path, sim_host):
    need_bundle("test_view::test_the_python_page_equals_the_cli_page")
    sc = short_mission(300.0)
    toml = tmp_path / "mission.toml"
    toml.write_text(sc.to_toml())
    out = tmp_path / "cli"
    subprocess.run([str(sim_host), "run", str(toml), "--out", str(out), "--no-plots", "--quiet"], check=True)
    cli_page = acs.view(out)
    assert cli_page == str(out / "replay.html")
    py_page = acs.run(sc).view(tmp_path / "py.html")
    a, b = channels(page_document(cli_page)), channels(page_document(py_page))
    assert set(a) == set(b)
    for name in a:
        assert np.array_equal(a[name].view(np.uint8), b[name].view(np.uint8)), name


def test_a_result_without_its_scenario_says_what_to_do(tmp_path):
    r = acs.RunResult({"run_status": "ok"}, ["t_s"], {"t_s": np.zeros(3)})
    with pytest.raises(acs.RunError, match="acs.view"):
        r.view(tmp_path / "x.html")


def test_a_missing_run_directory_is_a_run_error(tmp_path):
    with pytest.raises(acs.RunError):
        acs.view(tmp_path / "nothing-here")
