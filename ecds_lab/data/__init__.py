"""The data contract, below every other layer: measurements, the recorded columns and variables,
the sensor description, run metadata, and what a data file is.

storage writes and reads it, model and analysis compute on it; it imports none of them.
"""
