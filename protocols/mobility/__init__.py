"""Mobility models as behaviours (``behavior.py``): random waypoint and a random walk reflecting off the bounds.

They only move the robot, so they compose with any protocol on the same robot
(``behaviors = [{use = "random_walk", …}, {use = "flooding", …}]``). ``suite.py`` registers them. No oracle, no
conformance suite: their tests compare positions with the models' stationary distributions (docs/protocols/mobility.md).
"""
