"""``keepaway render``: one episode of a game log drawn frame by frame to a GIF (Pillow) or an MP4
(imageio-ffmpeg, the optional extra ``keepaway[render]``), for papers and slides.

Drawn as the viewer page draws it (viewer/static/index.html): the region, keepers blue and takers red
with their numbers and body directions, the ball, the keepers' GetOpen targets, and the episode, cycle
and hold time.
"""

from __future__ import annotations

import math
from pathlib import Path

from PIL import Image, ImageDraw

from keepaway.server.game_log import GameRecord, Show

MARGIN_M = 2.5
PLAYER_R_M = 0.45
BALL_R_M = 0.25
COLORS = {"l": (78, 168, 222), "r": (239, 71, 111)}
GRASS = (47, 107, 47)
LINES = (244, 244, 244)
FORMATS = (".gif", ".mp4")


def episode_shows(record: GameRecord, episode: int) -> list[Show]:
    """The shows of ``episode`` (from 1): from its start to the show before the next episode's start
    (for the last episode, before the cycle it ended at, or the last show of a log that stops during it).
    ValueError if there is no such episode."""
    starts = record.episode_starts
    if not 1 <= episode <= len(starts):
        raise ValueError(f"the game log has episodes 1..{len(starts)}, not {episode}")
    start = starts[episode - 1]
    if episode < len(starts):
        end = starts[episode]
    else:
        end = math.inf if record.episodes_end is None else record.episodes_end
    return [s for s in record.shows if start <= s.cycle < end]


def draw_show(record: GameRecord, show: Show, scale: float) -> Image.Image:
    """One frame as an RGB image, ``scale`` pixels per metre."""
    length, width = record.region()
    size = (round((length + 2 * MARGIN_M) * scale), round((width + 2 * MARGIN_M) * scale))
    image = Image.new("RGB", size, GRASS)
    g = ImageDraw.Draw(image)

    def at(x: float, y: float) -> tuple[float, float]:
        return (x + length / 2 + MARGIN_M) * scale, (y + width / 2 + MARGIN_M) * scale

    g.rectangle([at(-length / 2, -width / 2), at(length / 2, width / 2)], outline=LINES, width=2)
    keepers = {p.unum: p for p in show.players if p.side == "l"}
    for note in record.notes.get(show.cycle, []):
        tx, ty = at(*note.target)
        keeper = keepers.get(note.unum)
        if keeper is not None:
            g.line([at(keeper.x, keeper.y), (tx, ty)], fill=COLORS["l"], width=1)
        g.line([(tx - 5, ty - 5), (tx + 5, ty + 5)], fill=COLORS["l"], width=2)
        g.line([(tx + 5, ty - 5), (tx - 5, ty + 5)], fill=COLORS["l"], width=2)
    r = PLAYER_R_M * scale
    for p in show.players:
        cx, cy = at(p.x, p.y)
        g.ellipse([cx - r, cy - r, cx + r, cy + r], fill=COLORS[p.side])
        a = math.radians(p.body)
        g.line([(cx, cy), (cx + 1.9 * r * math.cos(a), cy + 1.9 * r * math.sin(a))], fill=(17, 17, 17), width=2)
        g.text((cx, cy - 1.9 * r), str(p.unum), fill=(255, 255, 255), anchor="mm")
    bx, by = at(show.ball[0], show.ball[1])
    b = BALL_R_M * scale
    g.ellipse([bx - b, by - b, bx + b, by + b], fill=(255, 255, 255), outline=(0, 0, 0))
    episode, start = record.episode_at(show.cycle)
    g.text((6, 4), f"episode {episode}  cycle {show.cycle}  hold {(show.cycle - start) / 10:.1f} s",
           fill=(255, 255, 255))
    return image


def render(record: GameRecord, episode: int, out: Path, scale: float = 24.0, fps: float = 10.0) -> int:
    """Write ``episode`` to ``out`` (.gif or .mp4) at ``fps`` frames per second (10: real time); returns
    the number of frames. ValueError for an unknown episode or format; RuntimeError when the MP4 writer
    (imageio-ffmpeg) is not installed."""
    suffix = out.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"{out}: the output must end in {' or '.join(FORMATS)}")
    shows = episode_shows(record, episode)
    images = (draw_show(record, show, scale) for show in shows)
    out.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        first = next(images)
        first.save(out, save_all=True, append_images=list(images), duration=round(1000 / fps), loop=0)
        return len(shows)
    try:
        import imageio_ffmpeg
    except ImportError:
        raise RuntimeError("writing MP4 needs imageio-ffmpeg: pip install 'keepaway[render]'") from None
    import numpy as np

    first = next(images)
    size = (first.width - first.width % 2, first.height - first.height % 2)  # even sides for yuv420p
    writer = imageio_ffmpeg.write_frames(str(out), size, fps=fps, macro_block_size=1)
    writer.send(None)
    for image in (first, *images):
        writer.send(np.ascontiguousarray(np.asarray(image)[: size[1], : size[0]]))
    writer.close()
    return len(shows)


__all__ = ["draw_show", "episode_shows", "render"]
