"""The simulated lab's own physics, written independently of ``ecds_lab.model`` (see docs/simulated_lab.md).

One module per part of the set-up: the Dodd & Deeds field solution, the coil and its former,
the plate, the temperatures, the slide's carriage and the bridge. ``ecm`` keeps the paper's
equivalent circuit model as the lab's physics for tests that need the analysis model to be exact.
"""
