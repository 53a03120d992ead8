"""The image viewer page of the glint images (``scene_images.html``; docs/guide/scenes.md#the-image-viewer):
one self-contained HTML file, written for the report's ``scene_images`` section and for ``glintlab images``.

Per scene it holds every method's render at the viewer's resolution as float16 radiance (deflated, base64
in ``<script type="text/plain">`` elements), the camera path as a lossless animated WebP of log-encoded
radiance with the pops the flicker table counts (a deflated bit mask), and a hand-written script
(``glintlab/data/report/viewer.js``) that applies the reader's exposure and tone curve, switches methods,
flips to the truth while a key is held, zooms to pixels and shows differences in false colour. A
Content-Security-Policy allows inline script and style and data: / blob: images only: no request leaves
the file.
"""
from __future__ import annotations

import base64
import html
import io
import json
import math
import zlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ..resources import data_path
from ..studies.scene_frames import FACETS, SMOOTH, TONE_CURVES, ViewerScene

PAGE = "scene_images.html"
CSP = "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data: blob:"
#: Frames per second of the camera path's animation (the path has a handful of frames: a slow loop).
FPS = 4
#: Stops the animation's 8-bit log encoding covers below its brightest code (1/18 stop per code).
VIDEO_STOPS = 14.0
#: zlib level of the stored images: level 4 is 3 % larger than 6 on the report's renders and 2.5 times faster.
DEFLATE_LEVEL = 4
#: Mantissa bits kept of the stored float16 values (of 10): rounded to 2^-7 relative, within the step of
#: an 8-bit display value at its brightest (sRGB 254 -> 255 is 2^-6.8 in radiance; darker steps are larger,
#: and the ACES shoulder widens them), at any exposure (the rounding is relative). 6 % smaller deflated
#: than 7 bits (2^-8) and 30 % smaller than all ten on the report's renders: the page's largest part.
MANTISSA_BITS = 6


def scale_log2(view: ViewerScene) -> int:
    """The power of two the stored float16 values are multiplied by: the default exposure rounded, so the
    smooth lobe sits near 1 (float16 keeps 11 significant bits from 6e-5 to 65504)."""
    return int(round(view.exposure))


def stored_half(radiance: np.ndarray, k: int) -> np.ndarray:
    """The float16 values the page stores of ``radiance`` x 2^k: rounded to float16 (saturating at its
    largest finite value), then to MANTISSA_BITS mantissa bits (half up, on the magnitude's bits)."""
    # float32 x 2^k is exact, so float32 and float64 radiance give the same float16 values.
    v = np.clip(np.nan_to_num(np.asarray(radiance, np.float32) * np.float32(2.0 ** k)), -65504.0, 65504.0)
    bits = v.astype("<f2").view("<u2").astype(np.uint32)
    drop = 10 - MANTISSA_BITS
    if drop:
        sign, mag = bits & 0x8000, bits & 0x7FFF
        mag = np.minimum(((mag + (1 << (drop - 1))) >> drop) << drop, 0x7BFF)  # 0x7BFF: 65504, not infinity
        bits = sign | mag
    return bits.astype("<u2").view("<f2")


def encode_image(radiance: np.ndarray, k: int) -> str:
    """base64 of the zlib-deflated :func:`stored_half` values of ``radiance`` x 2^k, row-major, little-endian."""
    return base64.b64encode(zlib.compress(stored_half(radiance, k).tobytes(), DEFLATE_LEVEL)).decode("ascii")


def decode_image(text: str, k: int, shape) -> np.ndarray:
    """The radiance (float64) an :func:`encode_image` string stores (what the page's script reads)."""
    half = np.frombuffer(zlib.decompress(base64.b64decode(text)), dtype="<f2").reshape(shape)
    return half.astype(np.float64) * 2.0 ** -k


def video_codes(values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """8-bit codes of the video: 0 for values <= 0, else 1 + 254 (log2(v) - lo) / (hi - lo), rounded,
    clipped to [1, 255]."""
    v = np.asarray(values, np.float32)  # 1/18 stop per code: float32's log2 is ample
    c = np.float32(1.0) + np.round(np.float32(254.0 / (hi - lo)) * (np.log2(np.maximum(v, np.float32(1e-30)))
                                                                      - np.float32(lo)))
    return np.where(v > 0, np.clip(c, 1, 255), 0).astype(np.uint8)


def video_values(codes: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The values a code stands for (the page's decoding): 0 for code 0, else 2^(lo + (c - 1)(hi - lo) / 254)."""
    c = np.asarray(codes, np.float64)
    return np.where(c > 0, 2.0 ** (lo + (c - 1.0) * (hi - lo) / 254.0), 0.0)


def tile_layout(keys, width: int, height: int) -> dict:
    """Where each tile sits in the video's frame: up to four columns, each tile padded to even sides."""
    tw, th = width + width % 2, height + height % 2
    cols = min(4, len(keys))
    return {"cols": cols, "rows": math.ceil(len(keys) / cols), "tile_w": tw, "tile_h": th,
            "at": {k: [(i % cols) * tw, (i // cols) * th] for i, k in enumerate(keys)}}


def encode_animation(path_data: dict, k: int, lo: float, hi: float, layout: dict) -> bytes:
    """The camera path's tiles (:func:`video_codes` of radiance x 2^k) as one lossless animated WebP (Pillow):
    the glints are single pixels and a lossy codec's errors would flicker. Measured on the report's frames:
    lossless WebP is 25 % smaller than lossless H.264 (x264, High 4:4:4 Predictive) and 40 % smaller
    than lossless VP9; the page decodes its frames one by one with WebCodecs' ImageDecoder, exactly."""
    from PIL import Image
    T, W, H = path_data["frames"], layout["cols"] * layout["tile_w"], layout["rows"] * layout["tile_h"]
    frames = np.zeros((T, H, W), np.uint8)
    for key, (x, y) in layout["at"].items():
        tile = path_data["tiles"][key]
        frames[:, y:y + tile.shape[1], x:x + tile.shape[2]] = video_codes(tile * np.float32(2.0 ** k), lo, hi)
    images = [Image.fromarray(f) for f in frames]
    buf = io.BytesIO()
    # Quality 0 (the least effort per method) at method 3: 6 % smaller than method 0 at 1.5 times its CPU
    # time (0.6 s a scene); methods 4-6 gain nothing more here, quality 100 4 % at 3 times. Lossy WebP is
    # larger, not smaller, on these frames (quality 90: 1.5 times the bytes; the glints' noise is the content).
    images[0].save(buf, "WEBP", save_all=True, append_images=images[1:], lossless=True, quality=0, method=3,
                   duration=round(1000 / FPS), loop=0)
    return buf.getvalue()


def _stats(view: ViewerScene, flicker) -> dict:
    """Per method, the flicker table's numbers the tabs show (empty without a table)."""
    if flicker is None:
        return {}
    rows = flicker[flicker.scene == view.name].set_index("method")
    out = {}
    for c in view.columns:
        if c["method"] in rows.index:
            r = rows.loc[c["method"]]
            own = r.get("own_pop_rate", r.pop_rate)
            out[c["method"]] = {"std_ratio": float(r.get("own_std_ratio", r.std_ratio)),
                                "pop_rate": float(r.pop_rate), "own_pop_rate": float(own)}
    return out


def scene_document(view: ViewerScene, blobs: dict, flicker=None, pool=None) -> dict:
    """The manifest entry of one scene; its images and video go into ``blobs`` (element id -> base64, or a
    future of it when ``pool``, an executor, encodes them: deflate and WebP release the GIL)."""
    k = scale_log2(view)
    run = pool.submit if pool is not None else (lambda f, *a: f(*a))
    images = {}
    for key, img in view.images.items():
        bid = f"gv-b{len(blobs)}"
        blobs[bid] = run(encode_image, img, k)
        images[key] = bid
    doc = {"name": view.name, "width": view.width, "height": view.height, "exposure": round(view.exposure, 4),
           "scale_log2": k, "images": images, "columns": view.columns, "stats": _stats(view, flicker),
           "facets": FACETS, "smooth": SMOOTH}
    p = view.path
    if p:
        keys = list(p["tiles"])
        layout = tile_layout(keys, p["width"], p["height"])
        top = max(float(np.max(t)) for t in p["tiles"].values()) * 2.0 ** k
        hi = math.ceil(math.log2(top)) if top > 0 else 0.0
        lo = hi - VIDEO_STOPS
        bid = f"gv-b{len(blobs)}"
        blobs[bid] = run(lambda: base64.b64encode(encode_animation(p, k, lo, hi, layout)).decode("ascii"))
        doc["video"] = {"id": bid, "width": p["width"], "height": p["height"], "frames": p["frames"], "fps": FPS,
                        "lo": lo, "hi": hi, **layout, "valid": p["valid"], "pop_rate": p["pop_rate"],
                        **pop_bits(p, blobs)}
    return doc


def pop_bits(path_data: dict, blobs: dict) -> dict:
    """The pops of every method as one bit mask (method, frame pair, pixel), each row np.packbits'
    big-endian bytes, deflated into ``blobs``; with the methods' order, the row length and the count per
    frame pair."""
    order = list(path_data["pops"])
    pixels, pairs = path_data["width"] * path_data["height"], path_data["frames"] - 1
    bits = np.zeros((len(order), pairs, pixels), bool)
    for i, m in enumerate(order):
        for t, idx in enumerate(path_data["pops"][m]):
            bits[i, t, idx] = True
    packed = np.packbits(bits, axis=-1)
    bid = f"gv-b{len(blobs)}"
    blobs[bid] = base64.b64encode(zlib.compress(packed.tobytes(), DEFLATE_LEVEL)).decode("ascii")
    return {"pops_id": bid, "pop_order": order, "pop_row_bytes": int(packed.shape[-1]),
            "pop_counts": {m: [int(len(idx)) for idx in path_data["pops"][m]] for m in order}}


def _script_json(obj) -> str:
    """JSON safe inside a <script> element."""
    return json.dumps(obj, separators=(",", ":")).replace("</", "<\\/")


def write_viewer(out, views: dict, title: str, intro: str = "", flicker=None) -> Path:
    """``out/scene_images.html``: the viewer of ``views`` (scene name -> :class:`ViewerScene`, page order),
    with the flicker table's numbers on the method tabs when ``flicker`` (the section's
    ``scene_images_flicker`` table) is given. Returns the page's path."""
    out = Path(out)
    blobs: dict = {}
    with ThreadPoolExecutor(max_workers=2) as pool:  # the encoders in C, on both cores
        manifest = {"title": title, "tones": list(TONE_CURVES),
                    "scenes": [scene_document(v, blobs, flicker, pool) for v in views.values()]}
        blobs = {bid: b.result() if hasattr(b, "result") else b for bid, b in blobs.items()}
    css = data_path("report", "viewer.css").read_text(encoding="utf-8")
    script = data_path("report", "viewer.js").read_text(encoding="utf-8")
    data = "".join(f'<script type="text/plain" id="{bid}">{text}</script>\n' for bid, text in blobs.items())
    page = (f"<!doctype html><html lang='en'><head><meta charset='utf-8'>"
            f"<meta http-equiv='Content-Security-Policy' content=\"{CSP}\">"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>{html.escape(title)}</title><style>{css}</style></head><body>\n"
            f"<header><h1>{html.escape(title)}</h1>{intro}</header>\n<main id='gv'></main>\n"
            f"<script type='application/json' id='gv-manifest'>{_script_json(manifest)}</script>\n{data}"
            f"<script>{script}</script>\n</body></html>\n")
    path = out / PAGE
    path.write_text(page, encoding="utf-8")
    return path


def manifest_of(page) -> dict:
    """The manifest a written viewer page carries (for tests and tools)."""
    text = Path(page).read_text(encoding="utf-8")
    start = text.index("id='gv-manifest'>") + len("id='gv-manifest'>")
    return json.loads(text[start:text.index("</script>", start)].replace("<\\/", "</"))


def blob_of(page, bid: str) -> str:
    """The base64 text of element ``bid`` of a written viewer page."""
    text = Path(page).read_text(encoding="utf-8")
    start = text.index(f'id="{bid}">') + len(f'id="{bid}">')
    return text[start:text.index("</script>", start)]
