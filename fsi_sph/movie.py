"""A movie of a run's snapshots (``fsi-sph plot RUN.h5 --movie``): one frame per snapshot,
drawn by :class:`~fsi_sph.plot_scene.SceneFigure` with its time stamp, written through
matplotlib's animation writers: MP4 (H.264) with the ffmpeg of the ``imageio-ffmpeg`` package
(or one on PATH), a GIF (Pillow) where no encoder is found."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path

from fsi_sph.plot_scene import DPI, SceneFigure, open_run, time_stamp

log = logging.getLogger(__name__)


def ffmpeg_path():
    """The ffmpeg executable: the one ``imageio-ffmpeg`` ships, else one on PATH, else None."""
    try:
        import imageio_ffmpeg

        return imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):
        return shutil.which("ffmpeg")


def _writer(fps, encoder):
    """(matplotlib movie writer, file suffix)."""
    import matplotlib
    from matplotlib import animation

    if encoder is not None:
        matplotlib.rcParams["animation.ffmpeg_path"] = encoder
        return animation.FFMpegWriter(fps=fps, codec="libx264",
                                      extra_args=["-pix_fmt", "yuv420p"]), ".mp4"
    log.warning("no ffmpeg found (pip install imageio-ffmpeg): writing a GIF")
    return animation.PillowWriter(fps=fps), ".gif"


def write_movie(path, out_dir, field=None, fps=10, encoder="auto", progress=True):
    """Write ``movie.mp4`` (or ``movie.gif``) in ``out_dir``; returns its path."""
    from tqdm import tqdm

    f, groups = open_run(path)
    with f:
        scene = SceneFigure(f, groups, field)
        writer, suffix = _writer(fps, ffmpeg_path() if encoder == "auto" else encoder)
        out = Path(out_dir) / f"movie{suffix}"
        out.parent.mkdir(parents=True, exist_ok=True)
        name = json.loads(f.attrs["config"])["case"]["name"]
        with writer.saving(scene.fig, str(out), dpi=DPI):
            for g in tqdm(groups, desc="movie", unit="frame", delay=2.0,
                          disable=None if progress else True):
                scene.draw(g, time_stamp(g, name))
                writer.grab_frame()
        scene.close()
    return out
