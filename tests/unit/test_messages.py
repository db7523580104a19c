"""Wire messages (transport/messages.py).

Typed decoding that names the failing field, round trips, and the world actions' validation shared by
scenarios and the control queryable.
"""

from __future__ import annotations

import msgpack
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from transport import MalformedMessage
from transport.messages import (
    ACTIONS,
    Ack,
    ControlCommand,
    Deliveries,
    Downlink,
    FrameIn,
    FrameOut,
    Inputs,
    JoinReply,
    JoinRequest,
    RobotDescr,
    RobotIn,
    RobotOut,
    RunInfo,
    Stop,
    Uplink,
    action_problem,
    decode,
    encode,
)


def raw(obj) -> bytes:
    return msgpack.packb(obj, use_bin_type=True)


def test_uplink_round_trip_and_short_wire_names():
    up = Uplink("h0", 3, [RobotOut(2, [0.1, 0.0], [FrameOut(None, "K", 1, b"\x01", [4])], {"role": "x"}, None)])
    data = encode(up)
    assert decode(data, Uplink, what="uplink") == up
    plain = msgpack.unpackb(data, raw=False)
    # a frame row ends with its realtime send stamp `at` (None in lockstep)
    frame = [None, "K", 1, b"\x01", [4], None]
    assert plain == {"h": "h0", "t": 3, "r": [[2, [0.1, 0.0], [frame], {"role": "x"}, None]]}


@pytest.mark.parametrize("bad,field", [
    ({"h": "h0", "t": "soon"}, "$.t"),
    ({"h": "h0", "t": True}, "$.t"),
    ({"t": 1}, "h"),
    ({"h": "h0", "t": 1, "r": {"0": []}}, "$.r"),
    ({"h": "h0", "t": 1, "r": [[-1, None, [], None, None]]}, "$.r[0][0]"),
    ({"h": "h0", "t": 1, "r": [[0, None, [[None, "", 1, b"", []]], None, None]]}, "$.r[0][2][0][1]"),
    ({"h": "h0", "t": 1, "r": [[0, None, [[None, "K", 2**63, b"", []]], None, None]]}, "$.r[0][2][0][2]"),
    ({"h": "h0", "t": 1, "r": [[0, None, [[None, "K", 1, "text", []]], None, None]]}, "$.r[0][2][0][3]"),
    ({"h": "h0", "t": 1, "r": [[0, None, [], {1: "a"}, None]]}, "$.r[0][3]"),
    ({"h": "h0", "t": 1, "extra": 1}, "extra"),
])
def test_bad_uplinks_are_refused_naming_the_field(bad, field):
    with pytest.raises(MalformedMessage) as err:
        decode(raw(bad), Uplink, what="uplink from h0")
    assert "uplink from h0" in str(err.value) and field in str(err.value), str(err.value)


def test_downlink_is_one_of_inputs_deliveries_stop_ack():
    inputs = Inputs.from_rows(4, 4.0, [RobotIn(1, [0.0, 0.0, 0.0], ([2], [1.0, 0.0]), [0], None)],
                              [FrameIn(2, "K", 1, b"\x00", 3.0)], {"target": [1.0, 1.0]})
    deliveries = Deliveries.of([FrameIn(2, "K", 1, b"\x00", 0.5)], [1, 3], [0, 0], [10.25, 10.5])
    for msg in (inputs, deliveries, Stop(4, gone=True), Ack(1.5)):
        assert decode(encode(msg), Downlink, what="downlink") == msg
    with pytest.raises(MalformedMessage):
        decode(raw({"t": 1}), Downlink, what="downlink")  # no tag


def test_deliveries_are_columns_with_each_frame_once():
    frames = [FrameIn(2, "K", 1, b"\x01", 0.5), FrameIn(5, "L", 9, b"\x02", 0.5)]
    msg = Deliveries.of(frames, [7, 8, 7], [0, 0, 1], [1.5, 1.5, 2.0], [[1.0, 0.5], None, [2.0, -1.0]])
    back = decode(encode(msg), Downlink, what="downlink")
    dst, refs, due = back.arrays()
    assert dst.tolist() == [7, 8, 7] and refs.tolist() == [0, 0, 1] and due.tolist() == [1.5, 1.5, 2.0]
    assert back.frames == frames and back.rab == [[1.0, 0.5], None, [2.0, -1.0]]
    assert msg.dst == np.array([7, 8, 7], dtype="<i4").tobytes()  # little-endian whatever the machine


@pytest.mark.parametrize("fields, complaint", [
    ({"dst": [1, 2], "refs": [0], "due": [1.0, 1.0]}, "dst, refs, due: 2, 1 and 2 copies"),
    ({"dst": [-1], "refs": [0], "due": [1.0]}, "negative robot id"),
    ({"dst": [1], "refs": [1], "due": [1.0]}, "refs: an index outside the 1 frames"),
    ({"dst": [1], "refs": [0], "due": [float("nan")]}, "due: a time that is not a finite number"),
    ({"dst": [1], "refs": [0], "due": [1.0], "rab": [[1.0]]}, "rab: a row that is not (range, bearing)"),
    ({"dst": [1], "refs": [0], "due": [1.0], "rab": []}, "rab: 0 rows for 1 copies"),
])
def test_bad_deliveries_are_refused_naming_the_column(fields, complaint):
    wire = {"type": "d", "frames": [[2, "K", 1, b"\x00", 0.5]],
            "dst": np.array(fields["dst"], dtype="<i4").tobytes(), "refs": np.array(fields["refs"], "<i4").tobytes(),
            "due": np.array(fields["due"], dtype="<f8").tobytes()}
    if "rab" in fields:
        wire["rab"] = fields["rab"]
    with pytest.raises(MalformedMessage) as err:
        decode(raw(wire), Downlink, what="downlink")
    assert complaint in str(err.value), str(err.value)
    wire["due"] = wire["due"][:-1]  # not a whole number of float64s
    with pytest.raises(MalformedMessage, match="8-byte items"):
        decode(raw(wire), Downlink, what="downlink")


def test_join_messages():
    assert decode(raw({}), JoinRequest, what="join").count is None
    for bad in ({"count": 0}, {"count": -3}, {"count": "all"}, {"count": True}, [1, 2]):
        with pytest.raises(MalformedMessage):
            decode(raw(bad), JoinRequest, what="join")
    reply = JoinReply("h0", b"k" * 32, 2, [RobotDescr(0, [0.0, 0.0, 0.0], [{"use": "beacon"}], "ground", 1.0, 1.0,
                                                      0.5)], RunInfo("lockstep", 1.0, 3, 10, 10.0, 0))
    assert decode(encode(reply), JoinReply, what="join reply") == reply


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=80))
def test_any_bytes_decode_or_raise_malformed(data):
    for kind in (Uplink, Downlink, JoinRequest):
        try:
            decode(data, kind, what="fuzz")
        except MalformedMessage:
            pass


def test_every_action_has_a_shape_and_valid_examples_pass():
    valid = {"kill": [1, 2], "kill_fraction": 0.5, "add": [{"pos": [1.0, 2.0]}], "cut": [[0, 1]],
             "restore": [[0, 1]], "partition": [[0], [1, 2]], "heal": True, "loss": 0.1,
             "move": {"object": "target", "pos": [1.0, 1.0]}, "stop": True}
    assert set(valid) == set(ACTIONS)
    for name, value in valid.items():
        assert action_problem({name: value}, robots=3, dims=2, objects={"target"}) is None, name
    assert action_problem({"kill": 0}, robots=3) is None


@pytest.mark.parametrize("action,words", [
    ({"explode": True}, "unknown command"),
    ({"kill": "all"}, "robot id"),
    ({"kill": []}, "robot id"),
    ({"kill": True}, "robot id"),
    ({"kill": [5]}, "no robot 5"),
    ({"loss": 2.0}, "[0, 1]"),
    ({"kill_fraction": "half"}, "[0, 1]"),
    ({"cut": [[0, "a"]]}, "pairs"),
    ({"cut": [[0, 1, 2]]}, "pairs"),
    ({"partition": 5}, "lists of robot ids"),
    ({"add": [{"pos": "here"}]}, "pos"),
    ({"add": [{"pos": [float("nan"), 0.0]}]}, "finite"),
    ({"move": {"object": "nowhere", "pos": [0.0, 0.0]}}, "no object"),
    ({"move": {"object": "target", "pos": "there"}}, "object = name"),
    ({"heal": False}, "must be true"),
    ({"kill": [1], "loss": 0.1}, "unknown command"),
])
def test_bad_actions_are_refused_with_a_reason(action, words):
    problem = action_problem(action, robots=3, dims=2, objects={"target"})
    assert problem is not None and words in problem, problem


def test_malformed_count_reads_the_overflow_entry():
    from transport.messages import MORE_MALFORMED, malformed_count

    assert malformed_count([]) == 0
    assert malformed_count(["a", "b"]) == 2
    assert malformed_count(["a", "b", f"{MORE_MALFORMED} 298"]) == 300


ROWS = [RobotIn(3, [0.5, 1.0, 0.1], ([4, 7], [1.0, 2.0, 3.0, 4.0]), [1, 0, 1], ["target"], [0.5, 0.25], None),
        RobotIn(4, [1.5, 2.0, -0.1], ([], []), [], [], None, None),
        RobotIn(9, [2.5, 3.0, 3.1], ([3], [0.5, 1.0]), [0], None, None, [1.0, 0.5])]
FRAMES = [FrameIn(7, "K", 1, b"\x01", 3.0), FrameIn(4, "N", 2, b"\x02", 3.0)]


def test_inputs_columns_round_trip_to_the_same_rows():
    msg = Inputs.from_rows(6, 6.0, ROWS, FRAMES, {"target": [1.0, 1.0]})
    got = decode(encode(msg), Downlink, what="downlink")
    assert got == msg and got.robots == ROWS and got.frames == FRAMES
    cols = got.columns()
    assert cols.ids == [3, 4, 9] and cols.sensed_ptr == [0, 2, 2, 3] and cols.inbox_ptr == [0, 3, 3, 4]
    assert cols.refs == [1, 0, 1, 0] and cols.sensed_at == [1.0, 2.0, 3.0, 4.0, 0.5, 1.0]
    assert cols.poses.tolist() == [r.pose for r in ROWS] and got.known == [["target"], [], None]
    # numbers are little-endian on the wire, whatever the machine
    plain = msgpack.unpackb(encode(msg), raw=False)
    assert plain["ids"] == (3).to_bytes(4, "little") + (4).to_bytes(4, "little") + (9).to_bytes(4, "little")
    assert plain["refs"][:4] == (1).to_bytes(4, "little")


@pytest.mark.parametrize("field,value,words", [
    ("ids", b"\x01\x00", "whole number"),
    ("ids", (-1).to_bytes(4, "little", signed=True) * 3, "negative"),
    ("poses", b"\x00" * 8, "poses"),
    ("sensed", b"\x00" * 4 * 4, "offsets"),  # all zero: does not end at the 3 sensed robots
    ("si", b"", "sx"),
    ("inbox", b"", "no offsets"),
    ("refs", (5).to_bytes(4, "little") * 4, "outside"),
    ("known", [["target"]], "rows for 3 robots"),
    ("rab", [None, None, [1.0]], "rab[2]"),
])
def test_inputs_whose_columns_do_not_fit_are_refused(field, value, words):
    plain = msgpack.unpackb(encode(Inputs.from_rows(6, 6.0, ROWS, FRAMES)), raw=False)
    plain[field] = value
    with pytest.raises(MalformedMessage) as err:
        decode(raw(plain), Downlink, what="downlink")
    assert words in str(err.value), str(err.value)


@pytest.mark.parametrize("kind,what", [(ControlCommand, "control command"), (Uplink, "uplink"),
                                       (JoinRequest, "join request")])
def test_a_message_nested_200000_levels_deep_is_malformed_not_a_recursion_error(kind, what):
    deep = b"\x82\xa3cmd\xa3add\xa4args" + b"\x91" * 200_000 + b"\xc0"
    with pytest.raises(MalformedMessage, match=f"bad {what}: "):
        decode(deep, kind, what=what)
    if kind is ControlCommand:  # its args are any value: the decoder goes down the nesting
        with pytest.raises(MalformedMessage, match="nested too deeply"):
            decode(deep, kind, what=what)
