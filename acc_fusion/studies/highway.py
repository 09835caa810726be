"""highway-env studies: FCW off and on over the same episodes (:func:`highway_study`), and the
rendered replay of a run with the fused gap, safety distance and warning level drawn on it."""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.levels import LEVEL_NAMES, WARNING_COLORS
from acc_fusion.core.outputs import check_output_file, temporary_beside, write_bytes_atomic
from acc_fusion.core.table import Table
from acc_fusion.core.validation import check_choice
from acc_fusion.metrics.benefit import Benefit, paired_benefit
from acc_fusion.metrics.summary import FCWSummary
from acc_fusion.sim.closed_loop import SimConfig, StepView, simulate
from acc_fusion.studies.compare import benefit_table, class_table, exposure_km, on_off_table
from acc_fusion.studies.crashes import CrashLog, chain
from acc_fusion.truth.highway.config import HighwayConfig, HighwayError
from acc_fusion.truth.highway.source import HighwaySource
from acc_fusion.warning.logic import WarningConfig
from acc_fusion.warning.safety import safety_distances

#: Replay formats: Pillow writes GIF, imageio with ffmpeg writes MP4.
REPLAY_SUFFIXES = (".gif", ".mp4")


#: Height of the replay's text band under the highway-env frame [px].
BAND_PX = 34


# -------------------------------------------------------------------- replays
def check_replay_path(path: str | os.PathLike) -> Path:
    """Check that a replay can be written to ``path`` (before the run) and return it.

    Raises:
        ConfigError: the suffix is not one of :data:`REPLAY_SUFFIXES`, or ``.mp4`` without
            imageio and ffmpeg.
        AccFusionError: the folder cannot be created or written, or ``path`` is a folder.
    """

    p = Path(path)
    suffix = p.suffix.lower()
    check_choice("the replay's file type", suffix, REPLAY_SUFFIXES)
    if suffix == ".mp4":
        try:
            import imageio  # noqa: F401
            import imageio_ffmpeg

            imageio_ffmpeg.get_ffmpeg_exe()
        except (ImportError, RuntimeError):
            raise ConfigError(
                "writing an .mp4 replay needs imageio and ffmpeg: pip install imageio "
                "imageio-ffmpeg (or write a .gif)"
            ) from None
    return check_output_file(p)


class Replay:
    """An ``on_step`` hook of :func:`acc_fusion.sim.closed_loop.simulate` that films a highway-env
    run.

    Every step it takes highway-env's ``rgb_array`` frame (centred on slot 0, the first
    controlled vehicle) and draws, for slot 0 and ``method``'s estimate: on the road, a white
    tick at the fused gap ahead of the ego's front bumper and a tick in the warning colour at
    the imminent safety distance; under the frame, a band with the time, the ego speed, the
    fused gap (and the true one), the safety distance and the warning level (green none, amber
    caution, red imminent).  The safety distance is ``warning``'s model at the true ego speed
    with the estimate's range-rate and lead acceleration.  :meth:`save` writes the file: GIF
    with Pillow, MP4 with imageio + ffmpeg, at the simulation frequency (real time).

    Args:
        source: a :class:`HighwaySource` opened with ``render=True``.
        method: the method whose estimate and warning level are drawn.
        warning: the warning settings (safety model and parameters).
        path: the replay file (checked by :func:`check_replay_path`).
    """

    def __init__(
        self, source: HighwaySource, method: str, warning: WarningConfig, path: str | os.PathLike
    ) -> None:
        self.source, self.method, self.warning = source, method, warning
        self.path = check_replay_path(path)
        self.fps = 1.0 / source.dt
        self._gif = self.path.suffix.lower() == ".gif"
        self._frames: list = []
        self._writer = None
        self._tmp: str | None = None
        if not self._gif:
            import imageio.v2 as imageio

            fd, self._tmp = temporary_beside(self.path, suffix=".mp4")
            os.close(fd)
            self._writer = imageio.get_writer(
                self._tmp, fps=self.fps, macro_block_size=2, format="FFMPEG"
            )

    def __call__(self, view: StepView) -> None:
        from PIL import Image, ImageDraw

        src, frame, i = self.source, view.frame, 0
        est = view.estimates[self.method]
        level = int(view.levels[self.method][i])
        valid = bool(est.valid[i])
        _, d_imm = safety_distances(
            self.warning.model,
            frame.ego_speed[i : i + 1],
            est.x[i : i + 1, 1] if valid else np.zeros(1),
            est.x[i : i + 1, 2] if valid else np.zeros(1),
            self.warning.params,
        )
        scene = src.render()
        h, w = scene.shape[:2]
        canvas = Image.new("RGB", (w, h + BAND_PX), (25, 25, 25))
        canvas.paste(Image.fromarray(scene), (0, 0))
        draw = ImageDraw.Draw(canvas)
        color = WARNING_COLORS[level][:3]
        if src.active[i]:
            for dist, fill in ((float(d_imm[0]), color), (float(est.gap[i]), (255, 255, 255))):
                if dist == dist and (valid or fill == color):  # NaN-free, gap only if tracked
                    x, y = src.pixel_ahead(i, dist)
                    draw.line([(x, y - 9), (x, y + 9)], fill=fill, width=3)
        draw.rectangle([0, h, 86, h + BAND_PX], fill=color)
        draw.text((6, h + 11), LEVEL_NAMES[level].upper(), fill=(0, 0, 0))
        true_gap = f"{frame.gap[i]:.1f}" if frame.has_leader[i] else "-"
        fused = f"{est.gap[i]:.1f} m" if valid else "no track"
        draw.text(
            (94, h + 4),
            f"t {frame.t:6.2f} s   ego {frame.ego_speed[i]:5.1f} m/s   {self.method}",
            fill=(230, 230, 230),
        )
        draw.text(
            (94, h + 18),
            f"fused gap {fused} (true {true_gap})   safety distance {float(d_imm[0]):.1f} m",
            fill=(230, 230, 230),
        )
        if self._gif:
            self._frames.append(canvas.quantize(colors=64, method=Image.Quantize.FASTOCTREE))
        else:
            self._writer.append_data(np.asarray(canvas))

    def save(self) -> Path:
        """Write the replay (atomically) and return its path."""
        import io

        if self._gif:
            if not self._frames:
                raise HighwayError("the replay has no frames: the run made no step")
            buf = io.BytesIO()
            first, *rest = self._frames
            first.save(
                buf,
                format="GIF",
                save_all=True,
                append_images=rest,
                duration=round(1000.0 / self.fps),
                loop=0,
            )
            write_bytes_atomic(self.path, buf.getvalue())
            self._frames = []
        else:
            self._writer.close()
            os.replace(self._tmp, self.path)
            self._tmp = None
        return self.path

    def discard(self) -> None:
        """Drop the frames (and the temporary MP4) without writing."""
        self._frames = []
        if self._writer is not None and self._tmp is not None:
            self._writer.close()
            Path(self._tmp).unlink(missing_ok=True)
            self._tmp = None


# -------------------------------------------------------------------- FCW off / on study
@dataclass
class HighwayRun:
    """What one run of :func:`run_highway` measured.

    Attributes:
        summaries: metrics of every method of the run.
        pairs: slots N (egos per episode).
        episodes: episodes run.
        crashes: vehicles highway-env marked crashed (any, including rear-ended ones).
        collisions: egos that ran into their leader (the forward collisions).
        replay: the replay written, if any.
        egos: every (episode, slot) that drove an ego.
        impacts: the impact speed of each of ``egos`` that ran into its leader.
    """

    summaries: dict[str, FCWSummary]
    pairs: int
    episodes: int
    crashes: int
    collisions: int
    replay: Path | None = None
    egos: set[tuple[int, int]] = field(default_factory=set)
    impacts: dict[tuple[int, int], float] = field(default_factory=dict)


def run_highway(
    config: HighwayConfig,
    sim: SimConfig,
    *,
    progress: bool = False,
    replay: str | os.PathLike | None = None,
    warnings_on: bool = True,
) -> HighwayRun:
    """Run the FCW pipeline of ``sim`` (its step replaced by the source's) on the episodes of
    ``config``; open loop when ``sim.drive`` is ``None``, else that method's alerts make the
    egos' drivers brake (with ``warnings_on`` false the drivers act, distracted or not, but
    hear no warning).  ``replay``: also film the run (see :class:`Replay`, which draws the
    driving method, else the last one)."""
    with HighwaySource(config, render=replay is not None, progress=progress) as source:
        film = None
        if replay is not None:
            film = Replay(source, sim.drive or sim.methods[-1], sim.warning, replay)
        log = CrashLog(source, lambda: [(source.episode, i) for i in range(source.n_pairs)])
        try:
            result = simulate(replace(sim, dt=source.dt), source=source,
                              on_step=chain(film, log), warnings_on=warnings_on)  # fmt: skip
        except BaseException:
            if film is not None:
                film.discard()
            raise
        written = film.save() if film is not None else None
        return HighwayRun(
            result.summaries,
            source.n_pairs,
            source.episode + 1,
            source.n_crashes,
            source.n_collisions,
            written,
            log.units,
            log.crashes,
        )


@dataclass
class HighwayStudy:
    """FCW metrics in highway-env traffic with FCW off (open loop) and on (closed loop)."""

    config: HighwayConfig
    off: HighwayRun
    on: HighwayRun

    def table(self):
        """Per method: false alarms, misses, lead time, forward collisions with FCW off."""
        cfg, n = self.config, self.off.episodes
        egos = "every vehicle" if cfg.pairs == "all" else "the controlled vehicles"
        t = on_off_table(
            f"FCW in highway-env traffic: {cfg.env}, {n} episode{'s' * (n != 1)} from seed "
            f"{cfg.seed}, egos: {egos} ({self.off.pairs} per episode), 95% intervals",
            self.off.summaries,
            self.on.summaries,
            subject="ego",
            same="same episodes",
        )
        t.notes.append(
            f"highway-env crashes (any vehicle, rear-ended ones included): {self.off.crashes} "
            f"with FCW off, {self.on.crashes} with FCW on"
        )
        return t

    def classes(self) -> Table:
        """Per method (FCW off): alerts per 100 km by class, missed crash-relevant situations."""
        title = f"Alert classes (judged from truth), {self.config.env}"
        return class_table(title, self.off.summaries)

    def benefit(self) -> Benefit:
        """The forward collisions of the egos that FCW avoided, paired by (episode, ego),
        with a bootstrap interval (:func:`acc_fusion.metrics.benefit.paired_benefit`)."""
        off, on = self.off, self.on
        km_off, km_on = exposure_km(off.summaries), exposure_km(on.summaries)
        return paired_benefit(off.egos | on.egos, off.impacts, on.impacts, km_off, km_on)

    def benefits(self) -> Table:
        """:meth:`benefit` as a table."""
        drive = next(iter(self.on.summaries))
        title = f"Crashes FCW avoids, {self.config.env}, egos, same episodes"
        return benefit_table(title, {drive: self.benefit()}, unit="egos (episode, slot)")


def highway_study(
    config: HighwayConfig,
    sim: SimConfig,
    *,
    progress: bool = False,
    render: str | os.PathLike | None = None,
) -> HighwayStudy:
    """Run the episodes of ``config`` with FCW off (every method of ``sim`` watching, no
    driver warned) and on (the alerts of ``sim.drive``, default the last method, make the
    drivers brake), one after the other on the same seeds.  With distracted drivers
    (``sim.driver.distraction``) the FCW-off run is a closed loop too, its drivers deaf to
    the warnings.  ``render``: film the FCW-on run."""
    drive = sim.drive or sim.methods[-1]
    distracted = sim.driver.distraction.rate > 0
    off_sim = replace(sim, drive=drive if distracted else None)
    off = run_highway(config, off_sim, progress=progress, warnings_on=False)
    closed = replace(sim, drive=drive, methods=(drive,))
    on = run_highway(config, closed, progress=progress, replay=render)
    return HighwayStudy(config, off, on)
