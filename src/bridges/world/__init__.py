"""The real world's stand-in: ground-truth room, noisy sensors over Zenoh, commanded robot.

Run it as ``python -m bridges.world --graph G --scenario S``; see :mod:`bridges.world.bridge`.
"""
