"""Closing the loop: design the measurement that decides an open question of the diagnosis, run it, diagnose again.

One module per job:

- ``questions``: the diagnosis's open questions (tied alternatives, effects with evidence but undetermined size,
  effects the data cannot test within what the campaign asks, a residual outside the library);
- ``rivals``: the competing fitted models of each question (the chain's model and each alternative);
- ``candidates``: the experiments the station can do (frequencies, directions, finer positions, holds, repeats),
  each validated against the station's travel and safety limits, with its lab time from the plan's estimate, read
  with the campaign's bridge settings (``recorded_bridge``: its noise is theirs);
- ``conditions``: the readings a candidate will take (distance, frequency, temperatures, times), from its plan and
  the station's thermal block;
- ``discrimination``: the T-criterion (Atkinson & Fedorov): the expected chi-square between rival models on a
  candidate, the rival refitted to the other's predicted readings;
- ``calibration_change``: what a smooth change of the new run's calibration absorbs, the nuisance a separation
  must survive to count;
- ``choice``: the chosen experiment, written as a normal experiment YAML with a header saying what it decides;
- ``investigate``: the loop diagnose -> plan -> run -> diagnose, and its ``investigate.json``.

See docs/planning.md.
"""
