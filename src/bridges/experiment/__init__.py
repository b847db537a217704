"""The caregiving stack as a whole: launching its processes, Experiment 1, its figures and the demo."""
