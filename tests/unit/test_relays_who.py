"""Swarm Relays' Fig. 6 "who recruits" analysis (fig6._who, fig6_who), pure: records in, summaries out."""

from __future__ import annotations

from protocols.relays.experiments.fig6 import _who, variant
from protocols.relays.experiments.fig6_who import ask_outcomes, compare, saved, summary


def test_the_variant_name_says_when_the_request_goes_to_the_base():
    assert variant({"wp": False, "ask": "plan", "route": "base"}) == "no WP (plan, to the base)"
    assert variant({"wp": False, "ask": "plan", "route": "first"}) == "no WP (plan)"


def test_who_turns_the_behaviour_s_ticks_into_seconds_and_names_the_recruiter():
    reports = {
        4: {"recruits": [[50, 1, 3, True, 49, 55, 7, 58], [70, 2, 3, True, None, 75, None, None]],
            "asked": [[49, 1, 3, False]], "head_ticks": 0, "head_stopped": 0},
        9: {"recruits": [], "asked": [], "head_ticks": 200, "head_stopped": 40},
        0: {"role": "root"},  # a report without the records (an older behaviour) is skipped
    }
    who = _who(reports, 0.2)
    assert who["recruits"] == [[4, 10.0, 1, 3, True, 9.8, 11.0, 7, 11.6], [4, 14.0, 2, 3, True, None, 15.0, None, None]]
    assert who["asks"] == [[4, 9.8, 1, 3, False]]
    assert who["head_stopped_s"] == [8.0] and who["head_s"] == [40.0]


def test_the_summary_counts_recruits_by_depth_waits_and_what_came_of_each_request():
    row = {"variant": "plan", "obstacle": False, "seed": 0, "time_factor": 2.5,
           "recruits": [[4, 10.0, 1, 3, True, 9.8, 11.0, 7, 11.6], [4, 14.0, 2, 3, True, 13.5, 15.0, None, None],
                        [6, 11.0, 1, 2, True, 11.0, 12.0, 8, 13.0]],
           "asks": [[4, 9.8, 1, 3, True], [4, 13.5, 2, 3, True], [5, 20.0, 3, 1, False]],
           "head_stopped_s": [8.0, 6.0], "head_s": [40.0, 30.0]}
    out = ask_outcomes(row)
    assert out == {(1, "joined"): 1, (2, "empty"): 1, (3, "no slot"): 1}
    s = summary([row])[("plan", False)]
    assert s["by_depth"] == {1: 2} and s["recruits_per_run"] == 2 and s["empty_slots_per_run"] == 1
    assert abs(s["request_to_join_s"] - 1.9) < 1e-9 and s["overlap"] == 1.0  # the two joined slots overlap
    assert s["head_stopped_s"] == 7.0 and s["head_s"] == 35.0


def test_the_saved_sweeps_give_the_references_of_the_same_placements(tmp_path):
    head = "targets,obstacle,wp,trial,seed,error,metric.kind,metric.targets,metric.obstacle,metric.wp,metric.seed,"
    rows = [f"3,false,{wp},{t},99,,tf,3,false,{wp},{t},{tf}" for wp, t, tf in
            [("false", 0, 3.0), ("false", 1, ""), ("false", 2, 2.5), ("true", 0, 2.0), ("true", 1, 2.1)]]
    (tmp_path / "fig6_sweep.csv").write_text(head + "metric.time_factor\n" + "\n".join(rows) + "\n")
    # WP lacks placement 2, so it is left out for trials [2, 0]; an unreached run's time factor is None
    assert saved(3, False, [2, 0], tmp_path) == {"stretched": [2.5, 3.0]}
    assert saved(3, False, [0, 1], tmp_path) == {"stretched": [3.0, None], "wp": [2.0, 2.1]}
    assert saved(3, True, [0], tmp_path) == {} and saved(4, False, [0], tmp_path) == {}
    assert compare([2.0, 2.2, None], [1.9, 2.0]).startswith("2.10 ± ")
    assert "(2/3, sd 0.14)" in compare([2.0, 2.2, None], [2.0, 2.1]) and "+2 %" in compare([2.0, 2.2], [2.0, 2.1])
    assert compare([2.0], [2.0, 2.1]).startswith("too few runs")
