"""Small scenarios shared by several test files."""


def small_flood(seed: int = 1) -> dict:
    return {
        "run": {"name": "small", "seed": seed, "ticks": 8},
        "robots": [{"count": 10, "placement": "line", "spacing": 0.9,
                    "behaviors": [{"use": "flooding", "origin": 0, "at": 1, "expiry": 5}]}],
    }
