"""ecds-lab: run an eddy current displacement sensor lab and explain its data."""

__version__ = "0.1.0"
