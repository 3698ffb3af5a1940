"""`timeseries.parquet` as a user reads it, with no code of ours: pyarrow, pandas and polars
each give the columns of `timeseries.csv` of the same run to the last bit of every f64,
and the in-memory columns of the same run from Python bit for bit (NaN and infinities
included, which the CSV writes as an empty field); the schema metadata names every
column's unit and the run."""

import json
import warnings

import numpy as np
import pandas as pd
import polars as pl
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import acs
from conftest import REPO, cli_run_finish, cli_run_start, read_csv_columns, same_bits

# A CMG slew, the rig in open loop (no flight code), and the mission: mode column, MEKF
# columns empty (NaN) while the filter is not running, wheels, magnetorquers, environment.
CASES = ["paper000/test1.toml", "paper003/rig-open-loop.toml", "modes/cubesat-mission.toml"]


def exact(a: np.ndarray, b: np.ndarray) -> bool:
    """Identical f64 bit patterns, NaN payloads included."""
    return a.shape == b.shape and bool(np.array_equal(a.view(np.uint64), b.view(np.uint64)))


@pytest.mark.parametrize("case", CASES)
def test_parquet_read_by_pyarrow_pandas_polars_equals_csv_and_the_python_run(case, sim_host, tmp_path):
    path = REPO / "scenarios" / case
    procs = {fmt: cli_run_start(sim_host, path, tmp_path / fmt, fmt=fmt) for fmt in ("csv", "parquet")}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", acs.RunStatusWarning)
        mem = acs.run(acs.Scenario.load(path)).columns
    for fmt, p in procs.items():
        cli_run_finish(p, tmp_path / fmt)
    names, csv = read_csv_columns(tmp_path / "csv" / "timeseries.csv")
    f = tmp_path / "parquet" / "timeseries.parquet"
    assert not (tmp_path / "parquet" / "timeseries.csv").exists()

    table = pq.read_table(f)
    assert table.column_names == names
    assert all(field.type == pa.float64() and not field.nullable for field in table.schema)
    readers = {
        "pyarrow": {n: table.column(n).to_numpy() for n in names},
        "pandas": {n: pd.read_parquet(f)[n].to_numpy() for n in names},
        "polars": {n: pl.read_parquet(f)[n].to_numpy() for n in names},
    }
    for reader, cols in readers.items():
        for n in names:
            assert cols[n].dtype == np.float64, (reader, n)
            assert same_bits(cols[n], csv[n]), f"{case}: {reader} column {n} differs from the CSV"
            assert exact(cols[n], mem[n]), f"{case}: {reader} column {n} differs from the Python run"
    # The CSV cannot tell NaN from ±inf; the Parquet file keeps each as it was.
    nonfinite = sum(int((~np.isfinite(mem[n])).sum()) for n in names)
    if case.startswith("modes/"):
        assert nonfinite > 0, "the mission's estimation columns start empty (NaN)"


def test_parquet_schema_metadata_names_units_and_the_run(sim_host, tmp_path):
    path = REPO / "scenarios/paper001/wheel-slew.toml"
    status, summary, (names, _) = cli_run_finish(cli_run_start(sim_host, path, tmp_path / "o"), tmp_path / "o")
    assert status == 0
    meta = {k.decode(): v.decode() for k, v in pq.read_schema(tmp_path / "o" / "timeseries.parquet").metadata.items()}
    units = json.loads(meta["units"])
    assert sorted(units) == sorted(names) and all(units[n] for n in names), units
    assert (units["t_s"], units["rate_x_rad_s"], units["q_w"], units["wheel1_speed_rpm"]) == ("s", "rad/s", "1", "rpm")
    assert meta["scenario"] == summary["scenario"] == "paper001-wheel-slew"
    assert meta["scenario_toml"] == path.read_text()
    assert int(meta["format_version"]) >= 1 and int(meta["protocol_version"]) >= 13
