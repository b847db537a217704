"""The computational core of the caregiving stack.

Scenario files, planar geometry, what a person can see, grid planning, walking
rollouts (PyBullet and numpy), the "imagine" requests of Algorithms 1 and 2, the
ground-truth world model, noisy sensors and candidate robot moves. Nothing here
touches the network or the working memory: agent processes wrap these functions.
"""
