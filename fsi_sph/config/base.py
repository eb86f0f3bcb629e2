"""Shared pieces of the config models: the strict, frozen base model and the constrained
number and name types."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

Vec2 = tuple[float, float]


Positive = Annotated[float, Field(gt=0.0)]


NonNegative = Annotated[float, Field(ge=0.0)]


Name = Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=64)]


class StrictModel(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)
