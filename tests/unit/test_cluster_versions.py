"""Which version differences between a sweep's client and its Dask cluster stop the sweep (below Dask)."""

from swarmactors.runs.cluster import SAME_VERSION, version_mismatches

CLIENT = {"python": "3.11.7.final.0", "dask": "2026.8.0", "distributed": "2026.8.0", "msgpack": "1.2.4",
          "cloudpickle": "3.1.3", "tornado": "6.6.1", "toolz": "1.2.0", "numpy": "2.4.6", "pandas": "3.1.1",
          "lz4": "4.4.5"}


def test_the_image_s_python_patch_level_and_missing_optional_packages_are_accepted():
    image = {**CLIENT, "python": "3.11.2.final.0", "pandas": None, "lz4": None}
    assert version_mismatches(CLIENT, {"scheduler": image, "worker tls://10.0.0.3:4000": image}) == []


def test_another_python_minor_version_is_named_with_the_peer():
    worker = {**CLIENT, "python": "3.12.1.final.0"}
    assert version_mismatches(CLIENT, {"worker tls://10.0.0.3:4000": worker}) == [
        "worker tls://10.0.0.3:4000 runs Python 3.12.1.final.0, this client 3.11.7.final.0"]


def test_every_package_that_carries_tasks_must_match_exactly():
    for package in SAME_VERSION:
        scheduler = {**CLIENT, package: "0.0.1"}
        assert version_mismatches(CLIENT, {"scheduler": scheduler}) == [
            f"scheduler has {package} 0.0.1, this client {CLIENT[package]}"]
    missing = {k: v for k, v in CLIENT.items() if k != "distributed"}
    assert version_mismatches(CLIENT, {"worker w": missing}) == ["worker w has distributed None, this client 2026.8.0"]
