"""The shipped stations, sensors and experiments (YAML), installed as ``ecds_lab.experiments``."""
