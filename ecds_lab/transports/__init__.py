"""Links to instruments: pyserial, pyvisa and transcript replay, all one interface."""

from ecds_lab.transports.base import Transport
from ecds_lab.transports.transcript import Transcript, TranscriptEvent

__all__ = ["Transcript", "TranscriptEvent", "Transport"]
