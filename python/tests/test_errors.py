"""Errors: bad input raises InputError (a TetradrillError) with the library's one line;
bad arrays raise ValueError."""

import numpy as np
import pytest

import tetradrill as td


def test_input_error_is_a_tetradrill_error():
    assert issubclass(td.InputError, td.TetradrillError)
    assert issubclass(td.TetradrillError, Exception)


def test_a_bad_trace_row_names_the_file_and_line(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("t,x,y,z,qw,qx,qy,qz,buttons\n0,0,0,0.6,1,0,0,0,1\n0.001,0,zero,0.6,1,0,0,0,1\n")
    with pytest.raises(td.InputError, match=f"{p}:3:"):
        td.Drilling("builtin:block:2", "sphere:0.1", trace=p)
    with pytest.raises(td.InputError, match=f"{p}:3:"):
        td.replay(trace=str(p))


def test_a_bad_scenario_file_names_the_file_and_line(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('mesh = "builtin:block:2"\nstiffness = -5.0\n')
    with pytest.raises(td.InputError, match=f"{p}:2:.*stiffness"):
        td.Drilling(scenario=p)
    p.write_text('mesh = "builtin:block:2"\n\nstifness = 5.0\n')
    with pytest.raises(td.InputError, match=f"{p}:3:"):
        td.Drilling(scenario=p)


def test_bad_settings():
    with pytest.raises(td.InputError, match="unknown scenario"):
        td.Drilling(scenario="builtin:nothing")
    with pytest.raises(td.InputError, match="stifness"):
        td.Drilling("builtin:block:2", stifness=5.0)
    with pytest.raises(td.InputError, match="stiffness"):
        td.Drilling("builtin:block:2", stiffness=-1.0)
    with pytest.raises(td.InputError, match="sphere:-1"):
        td.Drilling("builtin:block:2", "sphere:-1")
    with pytest.raises(td.InputError, match="Touching"):
        td.Drilling("builtin:block:2", "mesh:pen.mesh")
    with pytest.raises(td.InputError, match="young"):
        td.replay(body="soft", young=-5.0, ticks=5)
    with pytest.raises(td.InputError, match="touching takes a tet-mesh tool"):
        td.Touching("builtin:block:2", "sphere:0.1")


def test_bad_arrays_raise_value_error():
    d = td.Drilling("builtin:block:2", "sphere:0.1")
    with pytest.raises(ValueError, match="N x 3"):
        d.run(np.zeros((4, 5)))
    with pytest.raises(ValueError, match="3 drill flags for 4 poses"):
        d.run(np.zeros((4, 3)), drill=[True, False, True])
    with pytest.raises(ValueError, match="finite"):
        d.run([[0.0, 0.0, float("nan")]])
    with pytest.raises(ValueError, match="quaternion"):
        d.tick([0, 0, 1, 2, 0, 0, 0])
    assert d.ticks == 0, "a refused batch runs no tick"


def test_scenario_keys_as_a_dict():
    s = td.scenario("builtin:firmware-tooth", stiffness=5000.0)
    assert s["trace"] == "builtin:tooth-access"
    assert s["tool"] == "sphere:0.0007"
    assert s["stiffness"] == 5000.0
    assert set(s["regions"]) == {"1", "2", "3"}
