"""The caregiving application: the robot's six agents and the model of the room they imagine with.

``model`` is the like-me model (geometry, what a person sees, grid planning, walking rollouts, the
world model stepped for the joint imagination). The world bridge steps the same model as ground truth,
so it imports ``model`` from here; nothing in ``agents`` imports ``bridges``.
"""
