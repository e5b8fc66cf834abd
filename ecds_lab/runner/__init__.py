"""Running an experiment: from YAML to a plan of steps, executed on a station into a run file.

session         files -> checked configuration -> plan -> station -> run file (the ``run`` command)
plan            an experiment turned into steps; steps: the step dataclasses and their resume rules
steady_state    the SteadyState criterion of heater waits and the window that judges it
resume          which steps a resumed run executes
runner          walks the steps through their handlers; the run's ending (status, safe state)
handlers        one function per step class, registered in a table
context         what handlers work with: station, run file, tracked slide/heater/thermocouple state
regulation      waiting on a heater (control, bridge logging, timeout)
heaters         the supply driven towards each heater's goal; heater_control: the PI loop
identification  the IdentifyPlant step: a small heater pulse whose response proposes the loop's gains;
                plant_identification: the FOPDT fit and SIMC gains; temperature_hold: a hold's drift and verdict
interlocks      thermocouple readings under over-temperature and lost-thermocouple interlocks
slide_position  where the slide was put; rows: one run-file row; progress: the operator's bar
safe_state      heater off, slide stopped, no Ctrl-C meanwhile
"""
