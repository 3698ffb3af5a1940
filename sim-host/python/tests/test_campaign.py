"""acs.campaign: plan / run / merge from Python give the files and result of the CLI."""

import json
import subprocess

import acs
from conftest import REPO


def campaign_file(tmp_path, runs=8):
    base = acs.Scenario.load(REPO / "scenarios/paper000/test3.toml")
    base["duration_s"] = 10.0
    (tmp_path / "base.toml").write_text(base.to_toml())
    spec = tmp_path / "c.toml"
    spec.write_text(
        f'name = "py"\nbase = "{tmp_path / "base.toml"}"\nruns = {runs}\nseed = 7\n'
        '[[dispersion]]\nkey = "spacecraft.inertia_kgm2"\ndist = { type = "uniform", low = 0.9, high = 1.1 }\napply = "scale"\n'
        '[[dispersion]]\nkey = "initial.euler_deg"\ndist = { type = "rotation", max_deg = 20.0 }\n'
        '[[requirement]]\nname = "settled"\nkey = "final_error_deg"\nop = "<"\nvalue = 5.0\nprobability = 0.5\nconfidence = 0.5\n'
    )
    return spec


def files(d):
    return {p.relative_to(d): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def test_python_campaign_equals_cli_campaign(tmp_path, sim_host):
    spec = campaign_file(tmp_path)
    py, cli = tmp_path / "py", tmp_path / "cli"
    manifest = acs.campaign.plan(spec, py)
    assert len(manifest["runs"]) == 8
    shard = acs.campaign.run(py, jobs=2)
    assert shard["ran"] == 8 and shard["errors"] == 0
    result = acs.campaign.merge(py, plots=False)
    for args in (["plan", str(spec), "--out", str(cli)], ["run", str(cli), "--jobs", "2", "--quiet"], ["merge", str(cli), "--no-plots"]):
        subprocess.run([str(sim_host), "campaign", *args], check=False, capture_output=True)
    on_disk = json.loads((cli / "campaign.json").read_text())
    passed = result.pop("passed")
    assert result == on_disk
    assert passed == (on_disk["completed"] == on_disk["runs"] and all(q["verdict"] == "met" for q in on_disk["requirements"]))
    # the same files: manifest, every run's scenario, campaign.json, report.md
    a, b = files(py), files(cli)
    assert a.keys() == b.keys()
    for k in a:
        if k.name in ("manifest.json", "scenario.toml", "campaign.json"):
            assert a[k] == b[k], k
    # report.md also says how long the runs took on this host (not in campaign.json), and
    # its re-run commands name the campaign directory as it was given (issue 38)
    def host_time(text, d):
        return [x for x in text.decode().replace(str(d), "DIR").splitlines() if not x.startswith("Host time")]

    k = next(k for k in a if k.name == "report.md")
    assert host_time(a[k], py) == host_time(b[k], cli)
    # a second run resumes: nothing left to fly
    assert acs.campaign.run(py)["ran"] == 0


def test_campaign_errors(tmp_path):
    import pytest

    with pytest.raises(acs.CampaignError):
        acs.campaign.plan(tmp_path / "missing.toml", tmp_path / "out")
    with pytest.raises(acs.CampaignError):
        acs.campaign.run(tmp_path / "nothing-planned")
    with pytest.raises(acs.CampaignError, match="shard"):
        acs.campaign.run(tmp_path, shard="3/2")
