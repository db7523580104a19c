"""The JUnit ``time`` of a case is the case's whole time: both runs and the judging, not one run's tick loop."""

import asyncio
import xml.etree.ElementTree as ET

from swarmactors.runs import conformance as cf


class FakeResult:
    """What ``run_world`` returns, for a run whose tick loop took ``wall_s`` = 0.001 s."""

    trace_path = None
    checks: list[dict] = []

    def __getitem__(self, key):
        return {"trace_hash": "ab" * 16, "wall_s": 0.001}[key]

    def reports(self, family):
        return {}


def test_case_time_covers_both_runs(monkeypatch, tmp_path):
    calls = []

    async def fake_run_world(sc, out_dir, endpoints, run_id, processes=0):
        calls.append(processes)
        await asyncio.sleep(0.15)  # each run takes 0.15 s of wall time around its tick loop
        return FakeResult()

    import swarmactors.runs.launcher as launcher
    monkeypatch.setattr(launcher, "run_world", fake_run_world)
    monkeypatch.setattr(cf, "check_contract", lambda *a: None)
    fam, case = cf.case_by_name("flooding", cf.select("flooding", "quick")[0][1].name)
    assert case.determinism and case.scenario.get("run", {}).get("clock", "lockstep") == "lockstep"
    res = cf.run_case(fam, case, None, tmp_path)
    assert calls == [0, 2] and res.passed
    assert res.wall_s >= 0.3  # two runs of 0.15 s, not the first run's reported 0.001 s
    xml = ET.fromstring(cf.junit_xml([res], "flooding"))
    assert float(xml.find("testcase").get("time")) >= 0.3
