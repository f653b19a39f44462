"""Result files against tendrilkit.schema: columns, order and kinds; the one writer's precision."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tendrilkit import io, schema
from tendrilkit.exceptions import ExperimentError

ROOT = Path(__file__).resolve().parents[1]


def conforms(df: pd.DataFrame, table: schema.Table) -> list[str]:
    """What in ``df`` (read back from a CSV) does not match ``table``; [] when it conforms."""
    bad = []
    if tuple(df.columns) != table.columns:
        return [f"columns {list(df.columns)} != {list(table.columns)}"]
    for c, kind in zip(table.columns, table.kinds):
        col = df[c]
        present = col.dropna()
        if kind == "int":
            if col.isna().any() or (len(col) and col.dtype.kind not in "iu"):
                bad.append(f"{c}: expected integers, got {col.dtype}")
        elif kind == "Int":
            if len(present) and not (pd.api.types.is_numeric_dtype(present) and (present % 1 == 0).all()):
                bad.append(f"{c}: expected integers or empty, got {col.dtype}")
        elif kind == "float":
            if len(present) and not pd.api.types.is_numeric_dtype(present):
                bad.append(f"{c}: expected numbers, got {col.dtype}")
        elif kind == "bool":
            if not set(present.tolist()) <= {True, False}:
                bad.append(f"{c}: expected True/False, got {sorted(set(map(str, present)))[:3]}")
        elif kind == "str":
            if len(present) and not (col.dtype == object or pd.api.types.is_string_dtype(col)):
                bad.append(f"{c}: expected text, got {col.dtype}")
    return bad


# ------------------------------------------------------------------ the schema itself
def test_tables_are_consistent():
    for table in list(schema.RESULT_TABLES.values()) + [schema.frames_table(3), schema.SHAPE_CHANGE,
                                                        schema.TABLE1, schema.TABLE3, schema.SITE_COMPARISON]:
        assert len(table.columns) == len(table.kinds) == len(set(table.columns))
        assert set(table.kinds) <= set(schema.KINDS)
    assert schema.CURVES.columns == schema.PWC_CURVES.columns == ("frame", "time_s", "point", "x_mm", "y_mm", "z_mm")
    # the reprojection table is what the pipeline writes: 7 columns (the analyses read 5 of them)
    assert schema.REPROJECTION.columns == ("frame", "view", "section", "mean_px", "std_px", "max_px", "n_points")
    with pytest.raises(ValueError, match="kinds"):
        schema.Table("t.csv", ("a", "b"), ("int",))
    with pytest.raises(ValueError, match="unknown kind"):
        schema.Table("t.csv", ("a",), ("integer",))
    with pytest.raises(KeyError, match="pwc_r2"):
        schema.PWC_METRICS.require("frame", "pwc_r2")


def test_frames_columns_follow_the_views():
    three = schema.frames_columns(3)
    assert three[:4] == schema.FRAMES_HEAD.columns
    assert "tri_err_px_v3" in three and "tri_err_px_v4" not in three
    assert len(schema.frames_columns(4)) > len(three)
    t = schema.frames_table(3)
    assert t.kind("base_extended") == "bool" and t.kind("views_used") == "Int" and t.kind("length_mm") == "float"


# ------------------------------------------------------------------ the writer
def test_write_result_checks_columns_and_keeps_every_digit(tmp_path):
    seg = pd.DataFrame([(0, "tau", 0, 0.0, 87.78208912345, 0.0012345678912, -3.21e-7)],
                       columns=list(schema.PWC_SEGMENTS.columns))
    io.write_result(seg, tmp_path / "pwc_segments.csv", schema.PWC_SEGMENTS)
    back = pd.read_csv(tmp_path / "pwc_segments.csv")
    assert conforms(back, schema.PWC_SEGMENTS) == []
    # every digit survives (a torsion of 0.0012 1/mm kept 4 at ``%.6f``; an SSE of 26869 mm2 lost
    # decimals at ``%.10g``): the file reads back as the same doubles
    assert back.loc[0, "value_s0"] == 0.0012345678912 and back.loc[0, "value_s1"] == -3.21e-7
    assert back.loc[0, "s1_mm"] == 87.78208912345
    with pytest.raises(ValueError, match="pwc_segments.csv.*missing"):
        io.write_result(seg.drop(columns="kind"), tmp_path / "x.csv", schema.PWC_SEGMENTS)
    with pytest.raises(ValueError, match="out of order"):
        io.write_result(seg[list(reversed(seg.columns))], tmp_path / "x.csv", schema.PWC_SEGMENTS)
    assert not (tmp_path / "x.csv").exists()


def test_read_results_keeps_float_columns_float(tmp_path):
    # whole numbers in a float column, as another program may write them
    (tmp_path / "curves.csv").write_text("frame,time_s,point,x_mm,y_mm,z_mm\n0,0,0,1,0,3\n0,0,1,2,0,4\n")
    assert pd.read_csv(tmp_path / "curves.csv")["x_mm"].dtype.kind == "i"
    res = io.read_results(tmp_path)
    assert res.curves["x_mm"].dtype == float and res.curves["frame"].dtype.kind == "i"
    (tmp_path / "curves.csv").write_text("frame,time_s,point,x_mm,y_mm\n0,0,0,1,2\n")
    with pytest.raises(ExperimentError, match="missing column.*z_mm"):
        io.read_results(tmp_path)


# ------------------------------------------------------------------ every file of a reconstruct
@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    from tendrilkit.phantom import write_phantom_experiment

    base = tmp_path_factory.mktemp("schema")
    exp = write_phantom_experiment("S3", base / "exp", n_frames=2, seed=12)
    env = {**os.environ, "TENDRILKIT_PROGRESS": "0"}
    r = subprocess.run([sys.executable, "-m", "tendrilkit", "reconstruct", str(exp), "--out", str(base / "out"),
                        "--workers", "1", "--quiet"], cwd=ROOT, env=env, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    return base / "out"


@pytest.mark.slow
def test_every_file_of_a_reconstruct_matches_the_schema(run_dir):
    csvs = sorted(p.name for p in run_dir.glob("*.csv"))
    assert set(csvs) == set(schema.RESULT_TABLES) | {"frames.csv"}
    for name in csvs:
        df = pd.read_csv(run_dir / name)
        table = schema.frames_table(3) if name == "frames.csv" else schema.RESULT_TABLES[name]
        assert conforms(df, table) == [], name
        assert len(df) or name == "ordering.csv", name  # no crossing in 2 frames of S3: no decisions
    for p in sorted((run_dir / "frames").glob("frame_*.json")):
        d = json.loads(p.read_text())
        assert tuple(d) == schema.FRAME_FILE_KEYS
        assert tuple(d["result"]) == schema.FRAME_RECORD_KEYS
    res = io.read_results(run_dir)
    for name, table in schema.RESULT_TABLES.items():
        df = getattr(res, name[:-4])
        assert conforms(df, table) == [] and all(df[c].dtype == float for c in table.of_kind("float")), name
    assert res.frames.columns.tolist() == list(schema.frames_columns(3))


@pytest.mark.slow
def test_the_fit_command_writes_the_same_tables(run_dir, tmp_path):
    from tendrilkit.fitting import run_fit

    run_fit(run_dir / "curves.csv", tmp_path)
    for name in ("pwc_curves.csv", "pwc_segments.csv", "pwc_metrics.csv"):
        table = schema.RESULT_TABLES[name]
        fit, rec = pd.read_csv(tmp_path / name), pd.read_csv(run_dir / name)
        assert conforms(fit, table) == [], name
        assert fit.columns.tolist() == rec.columns.tolist(), name
        assert fit["frame"].unique().tolist() == rec["frame"].unique().tolist(), name
    assert np.isfinite(pd.read_csv(tmp_path / "pwc_segments.csv")["value_s0"]).all()
