"""A depth sensor model applied to rendered depth images (ray caster and Drake station alike).

Rendered depth is exact; a structured-light or stereo wrist camera is not. `apply_sensor` turns an
exact depth image into what such a camera returns, in this order:

1. depth edges: a pixel whose 4-neighbourhood spans more than `edge_jump` in depth sits on a
   silhouette; it drops out (no reading) with probability `edge_dropout`, else with probability
   `flying_pixel` it reads a depth between its near and far neighbours (a "flying pixel");
2. random dropout of any remaining pixel with probability `dropout`;
3. axial Gaussian noise with standard deviation sigma(z) = `noise_sigma0` + `noise_sigma2` z^2
   (the quadratic growth of triangulation error with range);
4. quantisation of the reading to multiples of `quantisation`.

A view may take several frames (`frames`): the arm holds still, so `read_depth` draws each frame's
errors independently and fuses them per pixel (`fuse_frames`: a pixel read in at least half the
frames keeps the mean of its readings near their median; flying pixels and dropouts in a minority
of frames go, the Gaussian noise averages down by about the square root of the frames). The model's
errors are independent between frames; on a real camera part of the error is fixed (pattern,
calibration), which no number of frames removes, so the gain measured here is an upper bound.

Presets (`SENSOR_PRESETS`): `ideal` returns the rendering unchanged; `realistic` is a short-range
structured-light camera at 0.25-0.7 m: sigma(z) = 0.5 mm + 5 mm/m^2 z^2 (1.3 mm at 0.4 m, 2.3 mm
at 0.6 m), 1 mm quantisation, half the silhouette pixels dropped and a fifth of the rest flying,
0.5 % random dropout, and eight frames per view (the robot's sensing since 2026-12-03: rows
measured before then took one, `--set sensor.frames=1`).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np


@dc.dataclass
class SensorConfig:
    """Depth error model of the wrist camera (all zero: the exact rendering)."""

    noise_sigma0: float = 0.0  #: m, range-independent standard deviation of the depth noise
    noise_sigma2: float = 0.0  #: 1/m, growth of the standard deviation with range squared
    quantisation: float = 0.0  #: m, readings are rounded to multiples of this (0: continuous)
    edge_jump: float = 0.01  #: m, a depth step this large between neighbours marks a silhouette
    edge_dropout: float = 0.0  #: probability that a silhouette pixel returns no reading
    flying_pixel: float = 0.0  #: probability that a kept silhouette pixel reads between surfaces
    dropout: float = 0.0  #: probability that any other pixel returns no reading
    frames: int = 1  #: depth frames taken per view and fused per pixel (`fuse_frames`)

    def __post_init__(self) -> None:
        for name in ("noise_sigma0", "noise_sigma2", "quantisation"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"sensor {name} must be >= 0, got {getattr(self, name)}")
        if not self.edge_jump > 0.0:
            raise ValueError(f"sensor edge_jump must be > 0 m, got {self.edge_jump}")
        for name in ("edge_dropout", "flying_pixel", "dropout"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"sensor {name} is a probability in [0, 1], "
                                 f"got {getattr(self, name)}")
        if isinstance(self.frames, bool) or not isinstance(self.frames, int) or self.frames < 1:
            raise ValueError(f"sensor frames must be an integer >= 1, got {self.frames!r}")

    @property
    def ideal(self) -> bool:
        """True when the model returns the rendering unchanged."""
        return (self.noise_sigma0 == 0 and self.noise_sigma2 == 0 and self.quantisation == 0
                and self.edge_dropout == 0 and self.flying_pixel == 0 and self.dropout == 0)

    def sigma(self, depth: np.ndarray | float) -> np.ndarray | float:
        """m, standard deviation of the noise at range `depth` (m)."""
        return self.noise_sigma0 + self.noise_sigma2 * np.square(depth)


#: the named sensors (`--sensor`); see the module docstring for the numbers
SENSOR_PRESETS: dict[str, SensorConfig] = {
    "ideal": SensorConfig(),
    "realistic": SensorConfig(noise_sigma0=0.0005, noise_sigma2=0.005, quantisation=0.001,
                              edge_jump=0.01, edge_dropout=0.5, flying_pixel=0.2,
                              dropout=0.005, frames=8),
}


def sensor_config(name: str = "ideal", **overrides: float) -> SensorConfig:
    """The preset called `name` with fields replaced by `overrides` (ValueError if unknown)."""
    if name not in SENSOR_PRESETS:
        raise ValueError(f"unknown sensor {name!r}: use one of {', '.join(SENSOR_PRESETS)}")
    fields = {f.name for f in dc.fields(SensorConfig)}
    unknown = sorted(set(overrides) - fields)
    if unknown:
        raise ValueError(f"unknown sensor field(s) {', '.join(unknown)}: "
                         f"fields are {', '.join(sorted(fields))}")
    return dc.replace(SENSOR_PRESETS[name], **{k: _field_value(k, v) for k, v in overrides.items()})


def _field_value(name: str, value: float | int) -> float | int:
    """`value` as the SensorConfig field `name` holds it (frames: an integer, else a float)."""
    if name != "frames":
        return float(value)
    if float(value) != int(value):
        raise ValueError(f"sensor frames must be an integer >= 1, got {value!r}")
    return int(value)


def noise_level_sensor(sigma: float) -> SensorConfig:
    """The realistic sensor with a constant noise `sigma` (m) instead of its range law (the
    noise-level curves; 0 keeps the silhouette effects and quantisation, no Gaussian noise)."""
    return dc.replace(SENSOR_PRESETS["realistic"], noise_sigma0=float(sigma), noise_sigma2=0.0)


def _neighbour_range(depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel, the nearest and farthest depth among it and its 4 neighbours (inf counts as
    far: a silhouette against nothing is a silhouette too)."""
    padded = np.pad(depth, 1, mode="edge")
    stack = np.stack([padded[1:-1, 1:-1], padded[:-2, 1:-1], padded[2:, 1:-1],
                      padded[1:-1, :-2], padded[1:-1, 2:]])
    return stack.min(axis=0), stack.max(axis=0)


def apply_sensor(depth: np.ndarray, sensor: SensorConfig, rng: np.random.Generator
                 ) -> np.ndarray:
    """The reading of `sensor` for exact `depth` (H, W metres, inf where nothing), float32.

    The same function serves the NumPy ray caster and the Drake station, so both observers see
    the same sensor. `rng` draws every random effect (fixed seed: the same reading).
    """
    exact = np.asarray(depth, dtype=float)
    if sensor.ideal:
        return exact.astype(np.float32)
    out = exact.copy()
    finite = np.isfinite(exact) & (exact > 0)
    near, far = _neighbour_range(np.where(finite, exact, np.inf))
    with np.errstate(invalid="ignore"):
        edge = finite & (far - near > sensor.edge_jump)
    drop = edge & (rng.random(exact.shape) < sensor.edge_dropout)
    flying = edge & ~drop & (rng.random(exact.shape) < sensor.flying_pixel)
    far_finite = np.where(np.isfinite(far), far, exact + 0.1)  # against nothing: 10 cm behind
    mix = rng.random(exact.shape)
    out[flying] = near[flying] + mix[flying] * (far_finite[flying] - near[flying])
    drop |= finite & ~edge & (rng.random(exact.shape) < sensor.dropout)
    noise = rng.standard_normal(exact.shape) * sensor.sigma(np.where(finite, out, 0.0))
    out = np.where(finite, out + noise, out)
    if sensor.quantisation > 0:
        out = np.where(finite, np.round(out / sensor.quantisation) * sensor.quantisation, out)
    out[drop] = np.inf
    return out.astype(np.float32)


def read_depth(depth: np.ndarray, sensor: SensorConfig, rng: np.random.Generator) -> np.ndarray:
    """The fused reading of `sensor.frames` frames of exact `depth` (one frame: `apply_sensor`,
    drawing the same random numbers as before frames existed)."""
    if sensor.frames == 1 or sensor.ideal:
        return apply_sensor(depth, sensor, rng)
    return fuse_frames(np.stack([apply_sensor(depth, sensor, rng)
                                 for _ in range(sensor.frames)]), sensor)


def _finite_median(frames: np.ndarray, finite: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Per pixel, the median of the finite readings along axis 0 (nan where none): the readings
    sorted with the missing ones last, the middle one or the mean of the middle two."""
    ordered = np.sort(np.where(finite, frames, np.inf), axis=0)
    low = np.take_along_axis(ordered, np.maximum(count - 1, 0)[None] // 2, axis=0)[0]
    high = np.take_along_axis(ordered, (count // 2)[None], axis=0)[0]
    high = np.where(count % 2 == 1, low, high)
    return np.where(count > 0, (low + high) / 2, np.nan)


def fuse_frames(frames: np.ndarray, sensor: SensorConfig) -> np.ndarray:
    """(K, H, W) readings of one view -> (H, W): per pixel, inf unless at least half the frames
    read it; else the mean of the readings within 3 sigma (plus one quantisation step) of their
    median, which leaves out flying pixels and averages the noise."""
    frames = np.asarray(frames, dtype=float)
    finite = np.isfinite(frames)
    count = finite.sum(axis=0)
    kept = count >= max(1, (frames.shape[0] + 1) // 2)
    median = _finite_median(frames, finite, count)
    band = 3.0 * sensor.sigma(np.where(kept, median, 0.0)) + sensor.quantisation
    near = finite & kept & (np.abs(frames - np.where(kept, median, 0.0)) <= band)
    total = np.where(near, frames, 0.0).sum(axis=0)
    used = near.sum(axis=0)
    out = np.full(frames.shape[1:], np.inf)
    good = kept & (used > 0)
    out[good] = total[good] / used[good]
    return out.astype(np.float32)
