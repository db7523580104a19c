"""Scenario values that are not numbers, too large, or escape the output directory (issue 28).

The fault campaign's malformed scenarios, rebuilt: each is refused with a ScenarioError naming the file and the
key, quickly, before anything is allocated or run.
"""

from __future__ import annotations

import time

import pytest

from swarmactors.runs.scenario import MAX_FILE_BYTES, MAX_ITEMS, ScenarioError, load

BASE = """[run]
ticks = 3
{run}
[radio]
{radio}
[world]
{world}
[[robots]]
{group}
{events}"""


def scenario(run="", radio="", world="", group="count = 3", events="") -> str:
    return BASE.format(run=run, radio=radio, world=world, group=group, events=events)


CASES = [
    ("dt-inf", scenario(run="dt = inf"), "run.dt", "not a finite number"),
    ("dt-nan", scenario(run="dt = nan"), "run.dt", "not a finite number"),
    ("noise-inf", scenario(group="count = 3\nnoise = inf"), "robots[0].noise", "not a finite number"),
    ("watchdog-inf", scenario(run="watchdog_s = inf"), "run.watchdog_s", "not a finite number"),
    ("heading-nan", scenario(group="count = 3\nheading = nan"), "robots[0].heading", "not a finite number"),
    ("range-inf", scenario(radio="range = inf"), "radio.range", "not a finite number"),
    ("group-range-inf", scenario(group="count = 3\nrange = inf"), "robots[0].range", "not a finite number"),
    ("spacing-inf", scenario(group='count = 3\nplacement = "line"\nspacing = inf'), "robots[0].spacing",
     "not a finite number"),
    ("duration-inf", scenario(run="duration = inf").replace("ticks = 3\n", ""), "run.duration", "not a finite"),
    ("latency-inf", scenario(radio="latency_s = inf"), "radio.latency_s", "not a finite number"),
    ("bounds-inf", scenario(world="bounds = [[0, 0], [inf, 5]]"), "world.bounds", "finite"),
    ("bounds-z-inverted", scenario(world="dims = 3\nbounds = [[0, 0, 5], [9, 9, 1]]"), "world.bounds", "min"),
    ("bounds-inverted", scenario(world="bounds = [[5, 0], [1, 9]]"), "world.bounds", "min < max"),
    ("name-escapes", scenario(run='name = "../../../../tmp/x"'), "run.name", "names a directory"),
    ("name-absolute", scenario(run='name = "/tmp/x"'), "run.name", "names a directory"),
    ("name-dots", scenario(run='name = ".."'), "run.name", "names a directory"),
    ("name-empty", scenario(run='name = ""'), "run.name", "names a directory"),
    ("nested", "a = " + "[" * 100_000 + "]" * 100_000, "syntax", "nested too deeply"),
    ("count-1e9", scenario(group="count = 1000000000"), "robots[0].count", "world.max_robots"),
    ("add-1e9", scenario(events="[[events]]\nat = 1\nadd = { count = 1000000000 }"), "events[0].add.count",
     "world.max_robots"),
    ("grid-1e7", scenario(group='count = 10000000\nplacement = "grid"'), "robots[0].count", "world.max_robots"),
    ("ring-2e7", scenario(group='count = 20000000\nplacement = "ring"'), "robots[0].count", "world.max_robots"),
    ("max-robots-huge", scenario(world="max_robots = 1000000000"), "world.max_robots", "1..1000000"),
    ("ticks-negative", scenario(run="ticks = -4").replace("ticks = 3\n", ""), "run.ticks", ""),
    ("seed-negative", scenario(run="seed = -1"), "run.seed", ""),
    ("loss-above-1", scenario(radio="loss = 1.5"), "radio.loss", ""),
]


@pytest.mark.parametrize("name,text,key,words", CASES, ids=[c[0] for c in CASES])
def test_malformed_values_are_refused_naming_file_and_key(tmp_path, name, text, key, words):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    t0 = time.monotonic()
    with pytest.raises(ScenarioError) as err:
        load(path)
    assert time.monotonic() - t0 < 5.0  # refused before anything large is allocated
    message = str(err.value)
    assert str(path) in message and key in message and words in message, message


def test_a_file_too_large_is_refused_before_it_is_read(tmp_path):
    path = tmp_path / "huge.toml"
    with path.open("wb") as f:
        f.truncate(MAX_FILE_BYTES + 1)  # sparse: nothing is written, the size is what counts
    with pytest.raises(ScenarioError, match="larger than"):
        load(path)


def test_invalid_utf8_names_the_file(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(scenario(run='name = "caf\xe9"').encode("latin-1"))
    with pytest.raises(ScenarioError) as err:
        load(path)
    assert str(path) in str(err.value) and "UTF-8" in str(err.value)


def test_a_directory_is_not_a_scenario(tmp_path):
    with pytest.raises(ScenarioError, match="directory"):
        load(tmp_path)


def _big_array(path, n: int = 1_500_000) -> None:
    """A 15 MB scenario whose world.objects is an array of n numbers (the campaign's 1.5 M-element file)."""
    items = ", ".join(["0.1234567"] * n)
    path.write_text('[run]\nticks = 3\n\n[[robots]]\ncount = 3\n\n[[robots]]\nbehaviors = [{ use = "beacon" }]\n'
                    f"positions = [[0, 0], [1, 1]]\n\n[world]\nbounds = [[0, 0], [4, 4]]\nobjects = [{items}]\n")


def test_a_file_of_too_many_items_is_refused_by_size_before_it_is_parsed(tmp_path, monkeypatch):
    """Parsing 1.5 M items takes ~10 s; the count of commas refuses them first, naming the key that holds them."""
    import tomllib

    path = tmp_path / "huge-array.toml"
    _big_array(path)
    assert path.stat().st_size < MAX_FILE_BYTES

    def never(_text):
        raise AssertionError("the file was parsed")

    monkeypatch.setattr(tomllib, "loads", never)
    with pytest.raises(ScenarioError) as err:
        load(path)
    assert err.value.key == "world.objects" and f"at most {MAX_ITEMS}" in str(err.value), str(err.value)


def test_the_item_count_names_arrays_of_tables_by_index(tmp_path):
    path = tmp_path / "positions.toml"
    points = ", ".join(["[0.5, 0.5]"] * 600_000)
    path.write_text(f"[run]\nticks = 3\n\n[[robots]]\ncount = 1\n\n[[robots]]\npositions = [{points}]\n")
    with pytest.raises(ScenarioError) as err:
        load(path)
    assert err.value.key == "robots[1].positions", str(err.value)


def test_the_command_exits_2_naming_the_key(tmp_path, capsys):
    from swarmactors.cli import main

    path = tmp_path / "huge-array.toml"
    _big_array(path)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{path}: world.objects: about 1500000 items" in err and not (tmp_path / "out").exists()


def test_a_scenario_below_the_item_count_is_parsed_as_usual(tmp_path):
    path = tmp_path / "many.toml"
    path.write_text(f"[run]\nticks = 3\n\n[[robots]]\npositions = [{', '.join(['[0.5, 0.5]'] * 2000)}]\n")
    assert len(load(path)["robots"][0]["positions"]) == 2000
