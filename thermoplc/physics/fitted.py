"""The fitted lumped-mass model: the effects it has, the shared, per-sensor and displacement parameters."""
from __future__ import annotations

from dataclasses import dataclass

from thermoplc.physics.effects import definition_of
from thermoplc.physics.primitives import DisplacementParams, SensorParams, Shared


@dataclass(frozen=True)
class Simulation:
    effects: tuple[tuple[str, int | None], ...]  # (name, sensor index for per-sensor effects), in order added
    shared: Shared
    sensors: tuple[SensorParams, ...]
    displacement: DisplacementParams

    def has(self, name: str) -> bool:
        return any(e == name for e, _ in self.effects)

    @property
    def filtered(self) -> bool:
        """True for an identified model: its temperatures follow the readings through the filter gains."""
        return any(p.filter_gain for p in self.sensors)

    def sensor_of(self, name: str) -> int | None:
        return next((s for e, s in self.effects if e == name), None)

    def parameter_count(self) -> int:
        """Fitted parameters: per sensor a time constant, a gain and a standstill load; the
        displacement's offset and a weight per sensor; with the structure lag its time constant and
        a second weight per sensor; and what each effect adds (its record says how many)."""
        k = len(self.sensors)
        structure = self.displacement.tau_struct_s is not None
        count = 3 * k + 1 + k + (1 + k) * structure + k * self.filtered
        return count + sum(definition_of(name).added_parameters(k) for name in {e for e, _ in self.effects})
