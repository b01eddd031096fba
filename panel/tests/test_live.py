"""circtest_live: the growing trace read incrementally, the polar deviations equal to the
analytic deviation of a simulated machine and to circana's F."""
import math
import os
import random

import pytest

import circtest_live as live
import circtest_logic as logic
from conftest import simulate

R_MM = 50.0
SCALE_X = 100e-6  # injected: the X scale 100 ppm long


@pytest.fixture
def scale_trace(tmp_path):
    # Very stiff servos: the only error is X's scale, about the centre 0,0.
    return simulate(tmp_path / "s.csv", "--d", "100", "--f", "1000", "--scale-x", str(SCALE_X),
                    "--kv-x", "1e9", "--kv-y", "1e9")


def grow(source_path, growing_path, chunk_sizes, poll):
    """Copies SOURCE to GROWING in chunks of the given sizes (lines cut anywhere), calling
    poll() after each, as the recorder's writes and the panel's timer interleave."""
    data = open(source_path, "rb").read()
    offset = 0
    with open(growing_path, "wb") as out:
        while offset < len(data):
            n = next(chunk_sizes)
            out.write(data[offset:offset + n])
            out.flush()
            offset += n
            poll()
    poll()


def test_deviation_is_the_injected_scale_error(scale_trace):
    source = live.LiveSource(scale_trace)
    source.tail.max_bytes_per_poll = 1 << 30
    assert source.poll() > 0
    assert source.polar.plane == "XY" and source.polar.radius_mm == R_MM
    assert [r.segment for r in source.polar.runs] == [1, 2]
    # A point at angle t moves radially by R*s*cos(t)^2: 5 µm at 0°, 0 at 90°.
    bins = source.polar.bins
    for run in source.polar.runs:
        assert run.high_um[0] == pytest.approx(R_MM * SCALE_X * 1000.0, abs=0.05)
        assert run.low_um[bins // 4] == pytest.approx(0.0, abs=0.05)
        assert run.high_um[bins // 8] == pytest.approx(R_MM * SCALE_X * 1000.0 / 2, abs=0.05)


def test_a_work_offset_centre_is_taken_in_machine_coordinates(scale_trace, tmp_path):
    # The program ran in a work offset: centre_mm is the centre there, centre_machine_mm the
    # one the recorded (machine) positions circle about.
    lines = open(scale_trace).read().split("\n")
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    lines[header:header] = ["# centre_mm: 30,40,0", "# centre_machine_mm: 0,0,0"]
    offset_trace = tmp_path / "offset.csv"
    offset_trace.write_text("\n".join(lines))
    source = live.LiveSource(str(offset_trace))
    source.tail.max_bytes_per_poll = 1 << 30
    assert source.poll() > 0
    for run in source.polar.runs:
        assert run.high_um[0] == pytest.approx(R_MM * SCALE_X * 1000.0, abs=0.05)
        assert run.low_um[source.polar.bins // 4] == pytest.approx(0.0, abs=0.05)


def test_extremes_equal_circanas_f(programs, scale_trace):
    # The LSC centre is the nominal one here (the error is symmetric): circana's F about it
    # and the live plot's extremes about the nominal circle are the same numbers.
    document = logic.run_json(logic.circana_analyze_command(programs, scale_trace))
    source = live.LiveSource(scale_trace)
    source.tail.max_bytes_per_poll = 1 << 30
    source.poll()
    for run, result in zip(source.polar.runs, document["runs"]):
        low, high = run.extremes_um()
        assert high == pytest.approx(result["F_max"] * 1000.0, abs=0.01)
        assert low == pytest.approx(result["F_min"] * 1000.0, abs=0.01)


def test_growing_file_gives_what_the_whole_file_gives(scale_trace, tmp_path):
    whole = live.LiveSource(scale_trace)
    whole.tail.max_bytes_per_poll = 1 << 30
    whole.poll()
    growing = str(tmp_path / "live.csv")
    source = live.LiveSource(growing)
    source.tail.max_bytes_per_poll = 4096  # catching up takes several polls
    rng = random.Random(7)
    sizes = iter(lambda: rng.randint(1, 20000), None)
    grow(scale_trace, growing, sizes, source.poll)
    assert source.tail.behind  # the last chunk was larger than one read
    while source.poll():
        assert len(source.tail.partial) < 4096
    assert not source.tail.behind
    assert source.rows == whole.rows == 44586
    assert len(source.polar.runs) == 2
    for a, b in zip(source.polar.runs, whole.polar.runs):
        assert a.samples == b.samples
        assert a.low_um == b.low_um and a.high_um == b.high_um


def test_replaced_file_is_read_again(scale_trace, tmp_path):
    path = tmp_path / "t.csv"
    path.write_bytes(open(scale_trace, "rb").read())
    source = live.LiveSource(str(path))
    source.tail.max_bytes_per_poll = 1 << 30
    source.poll()
    first = source.rows
    replacement = tmp_path / "new.csv"
    replacement.write_bytes(open(scale_trace, "rb").read())
    os.replace(replacement, path)  # a new inode, as the recorder's atomic rename makes
    source.poll()
    assert source.tail.restarted
    assert source.rows == first
    assert len(source.polar.runs) == 2


def test_waits_for_what_is_missing(tmp_path):
    path = tmp_path / "t.csv"
    source = live.LiveSource(str(path))
    assert source.poll() == 0 and source.status.startswith("waiting for")
    path.write_text("# plane: XY\nt,x,y,marker\n0,1,2,1\n")
    assert source.poll() == 0
    assert "radius_mm" in source.status
    path.write_text("# plane: XY\n# radius_mm: 5\nt,a,b,marker\n0,1,2,1\n")
    source = live.LiveSource(str(path))
    source.poll()
    assert source.status == "the trace has no x/y columns"


def test_feedback_columns_and_marker(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("# plane: YZ\n# radius_mm: 10\n# centre_mm: 0,1,2\n"
                    "# segments: 1:CCW:F500:YZ,2:CW:F500:YZ\n"
                    "t,y_fb,z_fb,marker,segment\n"
                    "0,11.002,2,0,0\n"       # outside the run: not drawn
                    "0.001,11.003,2,1,1\n"   # 3 µm at 0°
                    "0.002,1,12.001,1,1\n"   # 1 µm at 90°
                    "0.003,1,11.999,1,2\n")  # the next run: -1 µm at 90°
    source = live.LiveSource(str(path))
    assert source.poll() == 4
    runs = source.polar.runs
    assert [r.segment for r in runs] == [1, 2] and [r.samples for r in runs] == [2, 1]
    assert runs[0].high_um[0] == pytest.approx(3.0)
    assert runs[0].high_um[180] == pytest.approx(1.0)
    assert runs[1].low_um[180] == pytest.approx(-1.0)
    assert source.status == "run 2 of 2"


def test_partial_line_waits(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("# radius_mm: 1\nt,x,y\n0,1.0")
    source = live.LiveSource(str(path))
    assert source.poll() == 0
    with open(path, "a") as f:
        f.write("01,0\n")
    assert source.poll() == 1
    assert source.polar.runs[0].high_um[0] == pytest.approx(1.0)  # 1.001 mm on R1
    assert math.isinf(source.polar.runs[0].low_um[1])


def test_a_test_set_takes_each_runs_plane(tmp_path):
    # circgen --plane XY,YZ: one trace, each run's plane in `segments`; the centre x,y,z.
    path = tmp_path / "t.csv"
    path.write_text("# plane: XY,YZ\n# radius_mm: 10\n# centre_mm: 1,2,3\n"
                    "# segments: 1:CCW:F500:XY,2:CCW:F500:YZ\n"
                    "t,x,y,z,marker,segment\n"
                    "0,11.002,2,3,1,1\n"      # XY: 2 µm at 0°
                    "1,1,2,13.004,1,2\n")     # YZ: (y, z) = (2, 13.004): 4 µm at 90°
    source = live.LiveSource(str(path))
    assert source.poll() == 2
    xy, yz = source.polar.runs
    assert (xy.plane, yz.plane) == ("XY", "YZ")
    assert xy.high_um[0] == pytest.approx(2.0)
    assert yz.high_um[180] == pytest.approx(4.0)
    assert source.status == "run 2 of 2"
