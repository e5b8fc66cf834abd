"""Base class of every settings block of the simulated lab: strict (unknown keys are errors)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class Strict(BaseModel):
    """Pydantic model that refuses unknown keys, so a misspelt setting is an error, not ignored."""

    model_config = ConfigDict(extra="forbid")
