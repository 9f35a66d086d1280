"""SCIP 2.0 codec of the driver (ROS-free): the specification's examples, and scans of the
independently written emulator decoded exactly."""

import math

import numpy as np
import pytest
from hokuyo_node.urg_emulator import UrgEmulator

from hokuyo_node import scip
from hokuyo_node import scip_spec as spec

pytestmark = pytest.mark.unit

URG = scip.Geometry.from_info({k: str(v) for k, v in spec.URG_04LX.items()})


@pytest.mark.parametrize(("line", "sum_char"), [
    (b"00", "P"), (b"99", "b"), (b"DMIN:20", "4"), (b"DMAX:5600", "_"), (b"ARES:1024", "\\"), (b"AMIN:44", "7"),
])
def test_checksum_examples_of_the_specification(line, sum_char):
    assert chr(scip.checksum(line)) == sum_char


@pytest.mark.parametrize(("chars", "value"), [(b"CB", 1234), (b"1Dh", 5432), (b"m2@0", 16000000), (b"00", 0)])
def test_character_encodings(chars, value):
    assert scip.decode_value(chars) == value
    assert scip.decode_values(chars, len(chars)).tolist() == [value]


def test_vectorised_decoding_and_bad_characters():
    data = b"1Dh" * 3 + b"000"
    assert scip.decode_values(data, 3).tolist() == [5432, 5432, 5432, 0]
    with pytest.raises(scip.ScipError, match="multiple of 3"):
        scip.decode_values(b"1D", 3)
    with pytest.raises(scip.ScipError, match="encoding range"):
        scip.decode_values(b"\x20\x30\x30", 3)


def test_commands():
    assert scip.measure_command(44, 725, 1, 0, 0) == b"MD0044072501000\n"
    assert scip.measure_command(129, 639, 3, 1, 5, tag=b"x") == b"MD0129063903105;x\n"
    assert scip.scan_command(44, 725) == b"GD0044072501\n"


def test_reply_parsing_checks_terminator_and_status_sum():
    reply = scip.parse_reply(b"BM\n00P\n\n")
    assert (reply.echo, reply.status, reply.lines) == (b"BM", b"00", [])
    assert scip.parse_reply(b"SCIP2.0\n0\n\n").status == b"0"  # SCIP 1.1 style answer
    with pytest.raises(scip.ScipError, match="LF LF"):
        scip.parse_reply(b"BM\n00P\n")
    with pytest.raises(scip.ScipError) as err:
        scip.parse_reply(b"BM\n00Q\n\n")
    assert err.value.kind == "checksum"
    with pytest.raises(scip.ScipError, match="status"):
        scip.check_status(scip.parse_reply(b"MD0044072501000\n04T\n\n"), b"00")


def test_pp_answer_of_the_specification():
    # The specification's example lines (its MODL line's sum depends on spacing the OCR'd copy lost).
    modl = b"MODL:URG-04LX(Hokuyo Automatic Co.,Ltd.)"
    raw = (b"PP\n00P\n" + modl + b";" + bytes([scip.checksum(modl)]) + b"\nDMIN:20;4\nDMAX:5600;_\nARES:1024;\\\n"
           b"AMIN:44;7\nAMAX:725;o\nAFRT:384;6\nSCAN:600;e\n\n")
    info = scip.parse_info(scip.parse_reply(raw))
    geometry = scip.Geometry.from_info(info)
    assert (geometry.dmin, geometry.dmax, geometry.ares, geometry.amin, geometry.amax, geometry.afrt,
            geometry.rpm) == (20, 5600, 1024, 44, 725, 384, 600)
    with pytest.raises(scip.ScipError):
        scip.parse_info(scip.parse_reply(raw.replace(b"DMIN:20;4", b"DMIN:21;4")))


def test_geometry_of_the_urg_04lx():
    assert URG.angle(44) == pytest.approx(-2.0862, abs=1e-4)
    assert URG.angle(725) == pytest.approx(2.0923, abs=1e-4)
    assert URG.steps(-math.pi / 2, math.pi / 2) == (128, 640)
    assert URG.steps(-1.570, 1.570) == (129, 639)
    assert URG.steps(-3.0, 3.0) == (44, 725)  # clamped to the measurable range
    assert URG.steps(-3.0, 3.0, clamp=False) == (-104, 872)
    layout = URG.layout(129, 639, cluster=1, skip=0)
    assert layout["count"] == 511
    assert layout["angle_min"] == pytest.approx(URG.angle(129))
    assert layout["angle_max"] == pytest.approx(URG.angle(639))
    assert layout["angle_increment"] == pytest.approx(2 * math.pi / 1024)
    assert layout["time_increment"] == pytest.approx(0.1 / 1024)
    assert layout["scan_time"] == pytest.approx(0.1)
    assert (layout["range_min"], layout["range_max"]) == (0.02, 5.6)
    clustered = URG.layout(129, 639, cluster=3, skip=1)
    assert clustered["count"] == 171
    assert clustered["angle_max"] == pytest.approx(URG.angle(129 + 170 * 3))
    assert clustered["time_increment"] == pytest.approx(0.3 / 1024)
    assert clustered["scan_time"] == pytest.approx(0.2)


def test_error_codes_become_no_return():
    metres = scip.ranges_to_metres(np.array([0, 1, 19, 20, 5600]), 20)
    assert metres.tolist()[:3] == [math.inf] * 3
    assert metres[3] == np.float32(0.02) and metres[4] == np.float32(5.6)


def ranges_pattern(_now):
    return [(i * 7) % 5601 for i in range(769)]  # includes error codes (values < 20)


@pytest.mark.parametrize(("first", "last", "cluster"), [(44, 725, 1), (129, 639, 1), (100, 200, 3), (384, 384, 1)])
def test_emulator_scan_decodes_exactly(first, last, cluster):
    emulator = UrgEmulator(ranges=ranges_pattern)
    emulator.feed(b"BM\n", 0.0)
    raw = emulator.feed(scip.scan_command(first, last, cluster), 0.5)
    reply = scip.parse_reply(raw)
    scip.check_status(reply, spec.STATUS_OK)
    stamp, values = scip.parse_scan(reply, 3)
    pattern = ranges_pattern(0)
    expected = []
    for start in range(first, last + 1, cluster):
        group = pattern[start : min(last, start + cluster - 1) + 1]
        valid = [v for v in group if v >= 20]
        expected.append(min(valid) if valid else min(group))
    assert values.tolist() == expected
    assert stamp == 500


def test_damaged_data_blocks_are_reported():
    emulator = UrgEmulator(ranges=ranges_pattern)
    emulator.feed(b"BM\n", 0.0)
    reply = scip.parse_reply(emulator.feed(scip.scan_command(44, 725), 0.0))
    damaged = list(reply.lines)
    damaged[3] = damaged[3][:10] + bytes([damaged[3][10] ^ 0x01]) + damaged[3][11:]
    with pytest.raises(scip.ScipError) as err:
        scip.parse_scan(scip.Reply(reply.echo, reply.status, damaged), 3)
    assert err.value.kind == "checksum"
    short = list(reply.lines)
    del short[2]  # a block lost in the middle: the sums still match, the layout does not
    with pytest.raises(scip.ScipError, match="multiple of 3"):
        scip.parse_scan(scip.Reply(reply.echo, reply.status, short), 3)
