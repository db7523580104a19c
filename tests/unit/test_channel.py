"""The shared channel (``[radio.channel]``, world/channel.py) below Zenoh, against theory and textbook cases.

* pure ALOHA: N senders all in range of one receiver, each sending one frame per tick at a uniform time in a
  window of N·T/G frame times: the measured throughput S (successful frames per frame time) lies in the 99.9 %
  binomial interval of ``S = G·e^(−2G)``; slotted ALOHA (one slot per frame time) of ``S = G·e^(−G)``;
* the hidden terminal: A and C both in range of B but out of each other's carrier sense lose at B under CSMA
  as under ALOHA; moved into each other's carrier sense, CSMA defers one and B hears both;
* capture: a near and a far sender overlapping at one receiver: the near one's copy arrives, the far one's is
  a ``collision``; at equal distance both are lost;
* the SubT preset's delivery against distance: each distance's delivery count lies in the 99.9 % binomial
  interval of the closed form E[1{P ≥ sensitivity}·PRR(SNR)] over the log-normal shadowing (numerical
  quadrature), zero beyond 50 m; also with a transmit power that makes the curve fall inside the range;
* CSMA's ``deferred_too_long``; decisions independent of the frames' order; the scenario keys' rules;
* one end-to-end run with the channel on: the same trace hash in process and over Zenoh with K = 2 (slow).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from swarmactors.runs.inprocess import run_inprocess
from swarmactors.runs.scenario import ScenarioError, resolve
from transport.scenario import UNSET, Radio, SpecError
from transport.space import Grid, Prism, Space, space_from_spec
from world.channel import ChannelModel, mw, qpsk_prr
from world.linkrules import DROP_CAUSES, cause_name
from world.radio import Medium, Outgoing
from world.sensing import reach

Z = stats.norm.ppf(1 - 0.001 / 2)  # 99.9 % two-sided
BODY = 20  # bytes of every test frame's body


def medium(seed: int = 1, dt: float = 1.0, **channel) -> Medium:
    return Medium(Radio.from_dict({"range": 1000.0, "channel": channel}), seed, dt)


def run(m: Medium, tick: int, frames: list[Outgoing], pos: np.ndarray):
    n = len(pos)
    ranges = np.full(n, 1000.0)
    out = m.decide_batch(tick, frames, reach(pos, np.arange(n), ranges), np.ones(n, bool), pos, ranges)
    return {(int(out.src[f]), int(out.seq[f]), int(d)): (cause_name(c) if c >= 0 else "ok")
            for f, d, c in zip(out.frame.tolist(), out.dst.tolist(), out.cause.tolist(), strict=True)}


def star(n: int) -> np.ndarray:
    """A receiver (robot 0) at the origin and n senders on a circle of 1 m around it: all alike."""
    a = 2 * math.pi * np.arange(n) / n
    return np.vstack([[0.0, 0.0], np.column_stack([np.cos(a), np.sin(a)])])


def within_binomial(successes: int, trials: int, p: float) -> bool:
    half = Z * math.sqrt(p * (1 - p) / trials)
    return abs(successes / trials - p) <= half + 0.5 / trials


# ------------------------------------------------------------------------------------------------ ALOHA
N_SENDERS, TICKS = 200, 60


def throughput(mac: str, g: float) -> tuple[float, int, int]:
    """Measured S, successes and frames sent for offered load G (frames per frame time)."""
    airtime = ChannelModel(Radio.from_dict({"channel": {}}).channel, 0).airtime(np.array([BODY]))[0]
    slots = N_SENDERS / g
    window = float((slots + (0.5 if mac == "slotted" else 0.0)) * airtime)  # slotted: exactly `slots` whole slots
    m = medium(seed=7, mac=mac, shadowing_sigma_db=0.0, window_s=window)
    pos = star(N_SENDERS)
    ok = 0
    for tick in range(TICKS):
        frames = [Outgoing(s, 0, "B", tick, b"x" * BODY) for s in range(1, N_SENDERS + 1)]
        got = run(m, tick, frames, pos)
        assert set(got.values()) <= {"ok", "collision"}
        ok += sum(v == "ok" for v in got.values())
    sent = N_SENDERS * TICKS
    return ok / sent * g, ok, sent


@pytest.mark.parametrize("g", [0.25, 0.5, 1.0, 2.0])
def test_pure_aloha_throughput_is_g_exp_minus_2g(g):
    s, ok, sent = throughput("aloha", g)
    assert within_binomial(ok, sent, math.exp(-2 * g)), (g, s, g * math.exp(-2 * g))


@pytest.mark.parametrize("g", [0.25, 0.5, 1.0, 2.0])
def test_slotted_aloha_throughput_is_g_exp_minus_g(g):
    s, ok, sent = throughput("slotted", g)
    assert within_binomial(ok, sent, math.exp(-g)), (g, s, g * math.exp(-g))


def test_slotted_beats_pure_aloha_at_its_peak():
    assert throughput("slotted", 1.0)[0] > throughput("aloha", 0.5)[0] * 1.5  # 1/e against 1/(2e)


# ------------------------------------------------------------------------------------------------ hidden terminal
# A at 0, B at 20 m, C at 40 m; n = 3, L0 = 40 dB, 0 dBm: B hears each at -79 dBm (SNR 21 dB); A and C hear
# each other at -88 dBm.
LINE = np.array([[0.0, 0.0], [20.0, 0.0], [40.0, 0.0]])
HIDDEN = dict(shadowing_sigma_db=0.0, window_s=0.5e-3)  # both send within 0.5 ms: their 1.6 ms frames overlap


def both_to_b(mac: str, cs: float | None, ticks: int = 60) -> list[dict]:
    extra = {"cs_threshold_dbm": cs} if cs is not None else {}
    m = medium(seed=3, mac=mac, **HIDDEN, **extra)
    return [run(m, t, [Outgoing(0, 1, "D", t, b"x" * BODY), Outgoing(2, 1, "D", t, b"y" * BODY)], LINE)
            for t in range(ticks)]


def test_hidden_terminal_collides_at_b_with_csma_as_with_aloha():
    for mac in ("aloha", "csma"):
        for got in both_to_b(mac, -85.0 if mac == "csma" else None):  # -88 dBm < -85: A and C do not sense
            assert got == {(0, t, 1): "collision" for (_, t, _) in got} | {(2, t, 1): "collision"
                                                                           for (_, t, _) in got}, (mac, got)


def test_in_each_others_carrier_sense_csma_defers_and_b_hears_both():
    ticks = both_to_b("csma", -95.0)  # -88 dBm >= -95: A and C sense each other
    both = sum(set(got.values()) == {"ok"} for got in ticks)
    # the later sender defers unless it starts within one slot (20 us) of the first, i.e. in ~8 % of 0.5 ms
    assert both >= 0.8 * len(ticks), both
    assert all(v in ("ok", "collision") for got in ticks for v in got.values())


# ------------------------------------------------------------------------------------------------ capture
def test_capture_the_near_sender_survives_the_far_one():
    for near, far in ((5.0, 30.0), (30.0, 5.0)):
        pos = np.array([[0.0, 0.0], [near, 0.0], [-far, 0.0]])
        m = medium(seed=2, mac="aloha", shadowing_sigma_db=0.0, window_s=1e-5)
        got = run(m, 0, [Outgoing(1, 0, "D", 1, b"x" * BODY), Outgoing(2, 0, "D", 1, b"y" * BODY)], pos)
        assert got == {(1, 1, 0): "ok", (2, 1, 0): "collision"} if near < far else \
            {(1, 1, 0): "collision", (2, 1, 0): "ok"}, (near, far, got)
    pos = np.array([[0.0, 0.0], [10.0, 0.0], [-10.0, 0.0]])
    got = run(medium(seed=2, mac="aloha", shadowing_sigma_db=0.0, window_s=1e-5), 0,
              [Outgoing(1, 0, "D", 1, b"x" * BODY), Outgoing(2, 0, "D", 1, b"y" * BODY)], pos)
    assert set(got.values()) == {"collision"}


def test_a_louder_group_captures_at_equal_distance():
    """Two groups 10 m from the receiver; the group's tx_power_dbm (20 dBm against the channel's 0) wins."""
    raw = {"run": {"ticks": 1}, "radio": {"range": 100.0, "channel": {"shadowing_sigma_db": 0.0, "window_s": 1e-5}},
           "robots": [{"positions": [[0, 0], [10, 0]]}, {"positions": [[-10, 0]], "tx_power_dbm": 20}]}
    spec = resolve(raw, "loud.toml")
    from world.sim import Simulation

    power = Simulation(spec).robots.tx_power
    assert np.isnan(power[:2]).all() and power[2] == 20
    m = Medium(spec.radio, 1)
    pos = np.array([[0.0, 0.0], [10.0, 0.0], [-10.0, 0.0]])
    ranges = np.full(3, 100.0)
    out = m.decide_batch(0, [Outgoing(1, 0, "D", 1, b"x" * BODY), Outgoing(2, 0, "D", 1, b"y" * BODY)],
                         reach(pos, np.arange(3), ranges), np.ones(3, bool), pos, ranges, tx_power=power)
    assert {int(out.src[f]): int(c) for f, c in zip(out.frame, out.cause, strict=True)} == {
        1: DROP_CAUSES.index("collision"), 2: -1}


def test_a_receiver_that_transmits_hears_nothing_meanwhile():
    pos = np.array([[0.0, 0.0], [5.0, 0.0]])
    got = run(medium(mac="aloha", shadowing_sigma_db=0.0, window_s=1e-5), 0,
              [Outgoing(0, None, "B", 1, b"x" * BODY), Outgoing(1, None, "B", 1, b"y" * BODY)], pos)
    assert got == {(0, 1, 1): "collision", (1, 1, 0): "collision"}


# ------------------------------------------------------------------------------------------------ SubT curve
DISTANCES = [1.0, 5.0, 10.0, 20.0, 30.0, 40.0, 49.0, 51.0, 70.0]


def closed_form(d: float, tx_power: float) -> float:
    """SubT preset: P = tx − 40 − 25·log10(d) + 10·X, received when P ≥ −90 dBm with QPSK's PRR at −90 dBm noise."""
    if d > 50.0:
        return 0.0
    mean = tx_power - 40.0 - 25.0 * math.log10(max(d, 1.0))
    bits = BODY * 8

    def integrand(x: float) -> float:
        p = mean + 10.0 * x
        if p < -90.0:
            return 0.0
        snr = 10 ** ((p + 90.0) / 10)
        ber = 0.5 * math.erfc(math.sqrt(snr))
        return stats.norm.pdf(x) * (1 - ber) ** bits

    return integrate.quad(integrand, -12, 12, points=[(-90.0 - mean) / 10.0], limit=200)[0]


@pytest.mark.parametrize("tx_power", [27.0, -30.0])  # the preset's; one whose curve falls inside 50 m
def test_subt_delivery_against_distance_matches_the_closed_form(tx_power):
    n = len(DISTANCES) + 1
    pos = np.array([[0.0, 0.0]] + [[d, 0.0] for d in DISTANCES])
    m = medium(seed=11, preset="subt", mac="none", tx_power_dbm=tx_power)
    ticks = 1500
    ok = np.zeros(n, dtype=int)
    for t in range(ticks):
        got = run(m, t, [Outgoing(0, None, "B", t, b"x" * BODY)], pos)
        for (_, _, dst), what in got.items():
            assert what in ("ok", "below_sensitivity")
            ok[dst] += what == "ok"
    for i, d in enumerate(DISTANCES, start=1):
        p = closed_form(d, tx_power)
        assert within_binomial(int(ok[i]), ticks, p), (d, ok[i] / ticks, p)
    if tx_power == -30.0:  # a real curve: from almost always to almost never
        assert ok[1] > 0.85 * ticks and ok[len(DISTANCES) - 2] < 0.2 * ticks


def test_qpsk_prr_is_one_at_high_snr_and_zero_at_none():
    assert qpsk_prr(np.array([mw(30.0)]), np.array([1000.0]))[0] == pytest.approx(1.0)
    assert qpsk_prr(np.array([0.0]), np.array([160.0]))[0] == pytest.approx(0.5 ** 160)


# ------------------------------------------------------------------------------------------------ CSMA, order
def test_csma_drops_what_it_cannot_send_within_the_tick_as_deferred_too_long():
    pos = star(40)[1:] * 0.1  # 40 robots within 0.2 m: everyone senses everyone
    m = medium(seed=5, mac="csma", dt=0.01, shadowing_sigma_db=0.0)  # 10 ms tick: room for ~6 frames of 1.6 ms
    got = run(m, 0, [Outgoing(s, None, "B", 1, b"x" * BODY) for s in range(40)], pos)
    by_frame = {}
    for (src, _, _), what in got.items():
        by_frame.setdefault(src, set()).add(what)
    deferred = [s for s, w in by_frame.items() if w == {"deferred_too_long"}]
    sent = [s for s, w in by_frame.items() if "deferred_too_long" not in w]
    assert 3 <= len(sent) <= 8 and len(deferred) == 40 - len(sent), by_frame


@pytest.mark.parametrize("mac", ["aloha", "slotted", "csma"])
def test_a_decision_does_not_depend_on_the_order_of_the_frames(mac):
    rng = np.random.default_rng(4)
    pos = rng.uniform(0, 60, size=(30, 2))
    frames = [Outgoing(s, None if s % 3 else (s + 1) % 30, "B", 1, b"x" * int(rng.integers(1, 80)))
              for s in range(30)]
    a = run(medium(seed=9, mac=mac, window_s=0.02), 4, frames, pos)
    b = run(medium(seed=9, mac=mac, window_s=0.02), 4, frames[::-1], pos)
    assert a == b and "collision" in a.values()


def test_the_new_causes_are_counted_causes():
    assert {"below_sensitivity", "collision", "deferred_too_long"} <= set(DROP_CAUSES)


# ------------------------------------------------------------------------------------------------ scenario keys
def test_the_subt_preset_fills_what_the_table_does_not_give():
    c = Radio.from_dict({"channel": {"preset": "subt", "tx_power_dbm": 20}}).channel
    assert (c.max_range, c.path_loss_exponent, c.l0_db, c.shadowing_sigma_db, c.tx_power_dbm) == (50.0, 2.5, 40.0,
                                                                                                  10.0, 20)
    assert Radio.from_dict({}).channel is None  # off by default


@pytest.mark.parametrize(("channel", "key", "words"), [
    ({"mac": "tdma"}, "radio.channel.mac", "tdma"),
    ({"cs_threshold_dbm": -80}, "radio.channel.cs_threshold_dbm", 'applies only with mac = "csma"'),
    ({"aloha_slot_s": 0.01}, "radio.channel.aloha_slot_s", 'applies only with mac = "slotted"'),
    ({"bitrate_bps": 0}, "radio.channel.bitrate_bps", "0"),
    ({"colour": 1}, "radio.channel", "colour"),
])
def test_bad_channel_keys_are_refused_naming_the_key(channel, key, words):
    with pytest.raises((ScenarioError, SpecError)) as err:
        resolve({"run": {"ticks": 1}, "radio": {"channel": channel}, "robots": [{"count": 2}]}, "bad.toml")
    assert key in str(err.value) and words in str(err.value), str(err.value)


# ------------------------------------------------------------------------------------------------ end to end
def beacons_on_a_channel() -> dict:
    return {
        "run": {"name": "channel", "seed": 5, "ticks": 8},
        "radio": {"range": 40.0, "channel": {"mac": "csma", "window_s": 0.004}},
        "robots": [{"count": 12, "placement": "grid", "spacing": 12.0, "behaviors": [{"use": "beacon", "size": 40}]}],
        "checks": [],
    }


@pytest.mark.slow
def test_a_run_with_the_channel_has_the_same_trace_hash_in_process_and_over_zenoh(tmp_path):
    import swarmactors
    from swarmactors.runs.inprocess import run_inprocess

    inproc = run_inprocess(beacons_on_a_channel(), out=tmp_path / "k0")
    zenoh = swarmactors.run(beacons_on_a_channel(), out=tmp_path / "k2", processes=2)
    assert zenoh["trace_hash"] == inproc["trace_hash"]
    dropped = inproc["world"]["dropped"]
    assert dropped["collision"] > 0 and dropped["below_sensitivity"] > 0 and inproc["world"]["deliveries"] > 0


def test_the_plain_python_draws_of_carrier_sense_equal_the_array_ones():
    from world import rng
    from world.channel import uniform1

    for key in [(1, 2, 3), (5, -1, 7, 2**40), (0,)]:
        assert uniform1(99, *key) == float(rng.uniform(99, *key))
    m = ChannelModel(Radio.from_dict({"channel": {"max_range": 30.0, "shadowing_sigma_db": 6.0}}).channel, 3)
    a, b, d = np.array([1, 5, 9]), np.array([4, 2, 9]), np.array([3.3, 12.0, 40.0])
    assert m.power_dbm(7, a, b, d).tolist() == pytest.approx([m.link_dbm(7, int(x), int(y), float(z))
                                                              for x, y, z in zip(a, b, d, strict=True)], abs=1e-9)



def test_realtime_frames_go_out_at_their_senders_send_times():
    """Realtime: the start is ``Outgoing.at``; 0.5 ms apart the two 1.6 ms frames collide at B, 10 ms apart not."""
    radio = Radio.from_dict({"range": 1000.0, "channel": {"mac": "aloha", "shadowing_sigma_db": 0.0}})
    for gap, fate in ((0.0005, "collision"), (0.01, "ok")):
        m = Medium(radio, 1, dt=0.1, realtime=True)
        got = run(m, 3, [Outgoing(0, 1, "D", 1, b"x" * BODY, at=100.0),
                         Outgoing(2, 1, "D", 1, b"y" * BODY, at=100.0 + gap)], LINE)
        assert set(got.values()) == {fate}, (gap, got)


@pytest.mark.parametrize(("wall_db", "fate"), [(None, "occluded"), (10.0, "ok"), (30.0, "below_sensitivity")])
def test_a_wall_attenuates_instead_of_blocking_with_wall_loss_db(wall_db, fate):
    """10 m apart, -70 dBm in the open; behind a wall of 10 dB -80 dBm (heard), of 30 dB -100 dBm (not)."""
    channel = {"mac": "aloha", "shadowing_sigma_db": 0.0}
    if wall_db is not None:
        channel["wall_loss_db"] = wall_db
    m = Medium(Radio.from_dict({"range": 100.0, "occlusion": True, "channel": channel}), 1)
    pos = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    frames = [Outgoing(0, None, "B", 1, b"x" * BODY)]
    in_range = {0: np.array([1, 2]), 1: np.array([0, 2]), 2: np.array([0, 1])}
    occluded = {0: (np.array([2]), np.array([1]))}  # a wall between 0 and 1 only
    deliveries, drops, _ = m.decide(0, frames, in_range, np.ones(3, bool), pos, np.full(3, 100.0), occluded)
    got = {d: c for _s, _q, d, _k, c in drops} | {d: "ok" for d, *_ in deliveries}
    assert got == {1: fate, 2: "ok"}


def test_wall_loss_needs_occlusion():
    with pytest.raises(SpecError, match="needs radio.occlusion = true"):
        Radio.from_dict({"channel": {"wall_loss_db": 10}})


# ------------------------------------------------------------------------------------------------ walls
THIN_WALLS = [Prism(np.array([[3.0, -1.0], [3.1, -1.0], [3.1, 1.0], [3.0, 1.0]])),
              Prism(np.array([[6.0, -1.0], [6.1, -1.0], [6.1, 1.0], [6.0, 1.0]]))]


@pytest.mark.parametrize(("walls", "materials", "fate"), [
    ("link", (None, None), "ok"),  # one loss of 14 dB: -84 dBm
    ("crossing", (None, None), "below_sensitivity"),  # two walls of 14 dB: -98 dBm
    ("crossing", (1.0, None), "ok"),  # 1 + 14 dB: -85 dBm
    ("crossing", (1.0, 40.0), "below_sensitivity"),  # 41 dB
])
def test_walls_attenuate_per_crossing_and_per_material(walls, materials, fate):
    """10 m apart (-70 dBm in the open), two thin walls between robots 0 and 1; robot 2 in the open."""
    channel = {"mac": "aloha", "shadowing_sigma_db": 0.0, "wall_loss_db": 14.0, "walls": walls}
    m = Medium(Radio.from_dict({"range": 100.0, "occlusion": True, "channel": channel}), 1)
    m.use_space(Space([Prism(p.xy, loss_db=db) for p, db in zip(THIN_WALLS, materials, strict=True)]))
    pos = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    frames = [Outgoing(0, None, "B", 1, b"x" * BODY)]
    in_range = {0: np.array([1, 2]), 1: np.array([0, 2]), 2: np.array([0, 1])}
    occluded = {0: (np.array([2]), np.array([1]))}
    deliveries, drops, _ = m.decide(0, frames, in_range, np.ones(3, bool), pos, np.full(3, 100.0), occluded)
    got = {d: c for _s, _q, d, _k, c in drops} | {d: "ok" for d, *_ in deliveries}
    assert got == {1: fate, 2: "ok"}


def test_wall_loss_counts_prisms_by_material_and_grid_walls_by_runs_of_cells():
    """A thick wall of two map cells is one wall; two walls with a gap are two; prisms add their own loss."""
    blocked = np.array([[[False, True, True, False, True, False]]])  # one row: cells 1-2 a wall, cell 4 another
    grid = Grid((0.0, 0.0), 1.0, blocked, np.array([-math.inf, math.inf]), np.zeros((1, 6), dtype=bool))
    space = Space([Prism(THIN_WALLS[0].xy + [0.0, 5.0], loss_db=3.0)], grid)
    a = np.array([[0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [0.0, 5.0, 0.0]])
    b = np.array([[3.5, 0.5, 0.0], [5.5, 0.5, 0.0], [0.5, 0.9, 0.0], [9.0, 5.0, 0.0]])
    assert space.wall_loss(a, b, 10.0).tolist() == [10.0, 20.0, 0.0, 3.0]


def test_walls_crossing_needs_wall_loss_db_and_obstacles_keep_their_material():
    with pytest.raises(SpecError, match="needs wall_loss_db"):
        Radio.from_dict({"occlusion": True, "channel": {"walls": "crossing"}})
    channel = {"wall_loss_db": 5, "walls": "crossing"}
    sc = resolve({"run": {"ticks": 1}, "radio": {"occlusion": True, "channel": channel},
                  "world": {"obstacles": [{"box": [[0, 0], [1, 1]], "loss_db": 2.5},
                                          {"c_shape": {"center": [5, 5], "size": 2, "thickness": 0.2}, "loss_db": 7},
                                          {"box": [[8, 8], [9, 9]]}]},
                  "robots": [{"positions": [[20.0, 20.0]]}]})
    assert [o.loss_db for o in sc.world.obstacles] == [2.5, 7, 7, 7, UNSET]
    assert [p.loss_db for p in space_from_spec(sc.world.space_spec()).prisms] == [2.5, 7, 7, 7, None]


def test_a_run_with_walls_per_crossing_loses_what_one_wall_would_let_through(tmp_path):
    """In process: two robots 10 m apart behind two walls; one loss of 14 dB lets them talk, two do not."""
    got = {}
    for walls in ("link", "crossing"):
        channel = {"mac": "none", "shadowing_sigma_db": 0.0, "wall_loss_db": 14.0, "walls": walls}
        r = run_inprocess({"run": {"ticks": 5, "seed": 1, "name": walls}, "radio": {"range": 100.0, "occlusion": True,
                                                                      "channel": channel},
                           "world": {"obstacles": [{"box": [[3.0, -1.0], [3.1, 1.0]]},
                                                   {"box": [[6.0, -1.0], [6.1, 1.0]]}]},
                           "robots": [{"positions": [[0.0, 0.0], [10.0, 0.0]], "behaviors": [{"use": "beacon"}]}]},
                          out=tmp_path / walls)
        got[walls] = (r["world"]["deliveries"], r["world"]["dropped"]["below_sensitivity"])
    assert got == {"link": (8, 0), "crossing": (0, 10)}
