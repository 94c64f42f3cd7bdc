"""A picture of the analysed burn surface for the report: CPU only, no display, no OpenGL.

The mesh of surface/burn_surface.npz (processing/analysis/surface_map.py) is seen from above the burn, along its
mean surface normal, in orthographic projection (sizes on the picture do not change with depth, so a scale bar
holds over the whole burn). Skin keeps the reconstructed colours (mesh/surface.ply beside it, the same
vertices); the burn is painted as surface_map paints burn_surface.glb (PAINT, blended by the fused probability q),
with a dark outline where q crosses 0.5. Lambert shading shows the relief. A numpy z-buffer rasterises the
triangles in batches of equal bounding-box size.
"""

from __future__ import annotations

import logging
from pathlib import Path

import cv2
import numpy as np

from processing.analysis.surface_map import PAINT
from schemas.errors import InvalidInput

log = logging.getLogger(__name__)

BACKGROUND = 255
SKIN_FALLBACK = np.array([0.78, 0.7, 0.64])
OUTLINE = np.array([20, 20, 20], np.uint8)
PAINT_OPACITY = 0.55
"""Lighter than burn_surface.glb's 0.8: on paper the wound bed's texture should show through the paint; the
outline at q = 0.5 carries the boundary."""
MARGIN = 1.7
"""The frame spans the burn's extent times this (skin around it for context), within the mesh's extent."""
MIN_FRAME_SHARE = 0.35
"""...and at least this share of the mesh's extent, so a small burn is not shown magnified out of context."""
PLY_TYPES = {
    "char": "i1",
    "uchar": "u1",
    "short": "<i2",
    "ushort": "<u2",
    "int": "<i4",
    "uint": "<u4",
    "float": "<f4",
    "double": "<f8",
}


def read_ply_vertices(path: Path) -> dict[str, np.ndarray]:
    """The vertex properties (x, y, z, nx..., red...) of a binary little-endian PLY, as Open3D writes it."""
    with open(path, "rb") as handle:
        if handle.readline().strip() != b"ply":
            raise InvalidInput(f"{path} is not a PLY file")
        fields, count, in_vertex, binary = [], 0, False, False
        for raw in iter(handle.readline, b""):
            words = raw.decode("ascii", "replace").split()
            if words[:1] == ["format"]:
                binary = words[1] == "binary_little_endian"
            elif words[:1] == ["element"]:
                in_vertex = words[1] == "vertex"
                count = int(words[2]) if in_vertex else count
            elif words[:1] == ["property"] and in_vertex:
                if words[1] == "list" or words[1] not in PLY_TYPES:
                    raise InvalidInput(f"{path}: vertex property {' '.join(words[1:])} is not supported")
                fields.append((words[2], PLY_TYPES[words[1]]))
            elif words[:1] == ["end_header"]:
                break
        if not binary:
            raise InvalidInput(f"{path} is not a binary little-endian PLY")
        data = np.fromfile(handle, dtype=np.dtype(fields), count=count)
    return {name: data[name] for name, _ in fields}


def _skin(vertices: np.ndarray, mesh_ply: Path | None) -> tuple[np.ndarray, np.ndarray | None]:
    """Vertex colours in [0, 1] and the PLY's normals, from the reconstructed mesh when it matches the npz."""
    if mesh_ply is None or not mesh_ply.is_file():
        log.info("no reconstructed mesh beside the surface: the skin is drawn in one colour")
        return np.tile(SKIN_FALLBACK, (len(vertices), 1)), None
    props = read_ply_vertices(mesh_ply)
    if len(props.get("x", ())) != len(vertices):
        log.warning("%s does not hold the surface's vertices: the skin is drawn in one colour", mesh_ply)
        return np.tile(SKIN_FALLBACK, (len(vertices), 1)), None
    normals = np.stack([props[k] for k in ("nx", "ny", "nz")], 1) if "nx" in props else None
    if "red" not in props:
        return np.tile(SKIN_FALLBACK, (len(vertices), 1)), normals
    colours = np.stack([props[k] for k in ("red", "green", "blue")], 1).astype(np.float32)
    return colours / (255.0 if props["red"].dtype == np.uint8 else 1.0), normals


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(float(np.linalg.norm(v)), 1e-12)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area-weighted face normals (by winding) and the unit vertex normals summed from them."""
    tri = vertices[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    corners = faces.ravel()
    summed = np.stack([np.bincount(corners, np.repeat(face_n[:, k], 3), minlength=len(vertices)) for k in range(3)], 1)
    return face_n, summed / np.maximum(np.linalg.norm(summed, axis=1, keepdims=True), 1e-12)


def view_basis(face_n, faces, burn, ply_normals, scaled) -> np.ndarray:
    """Rows: right, up, towards the viewer. The viewer looks down the burn's area-weighted mean normal, oriented
    like the reconstruction's normals (which face the cameras), else, when scaled, to +z (the cameras' side of
    the marker plane)."""
    in_burn = burn[faces].any(axis=1) if burn.any() else np.ones(len(faces), bool)
    towards = _unit(face_n[in_burn].sum(axis=0))
    if ply_normals is not None:
        reference = ply_normals[burn].sum(axis=0) if burn.any() else ply_normals.sum(axis=0)
        towards = towards if towards @ reference >= 0 else -towards
    elif scaled and towards[2] < 0:
        towards = -towards
    up = np.array([0.0, 1.0, 0.0]) if abs(towards[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    up = _unit(up - (up @ towards) * towards)
    return np.stack([np.cross(up, towards), up, towards])


def _frame(plane: np.ndarray, burn: np.ndarray, width: int, height: int) -> tuple[np.ndarray, float]:
    """The picture's centre (plane coordinates) and its scale (pixels per mesh unit)."""
    lo, hi = plane.min(axis=0), plane.max(axis=0)
    pts = plane[burn] if burn.any() else plane
    b_lo, b_hi = np.percentile(pts, 1, axis=0), np.percentile(pts, 99, axis=0)
    centre = (b_lo + b_hi) / 2
    span = np.clip(np.maximum((b_hi - b_lo) * MARGIN, (hi - lo) * MIN_FRAME_SHARE), 1e-9, hi - lo + 1e-9)
    return centre, float(min(width / span[0], height / span[1]))


def rasterise(xy: np.ndarray, depth: np.ndarray, faces: np.ndarray, width: int, height: int):
    """Z-buffer: per pixel, the nearest face (-1 for none) and the barycentric weights of its corners.

    Pixel centres are at integer coordinates; larger depth is nearer. Faces are batched by the size of their
    bounding box (rounded up to a power of two), so each batch is one array operation."""
    tri, depth = xy.astype(np.float32)[faces], depth.astype(np.float32)
    x0 = np.maximum(np.ceil(tri[..., 0].min(1)), 0).astype(np.int64)
    y0 = np.maximum(np.ceil(tri[..., 1].min(1)), 0).astype(np.int64)
    x1 = np.minimum(np.floor(tri[..., 0].max(1)), width - 1).astype(np.int64)
    y1 = np.minimum(np.floor(tri[..., 1].max(1)), height - 1).astype(np.int64)
    keep = (x1 >= x0) & (y1 >= y0)
    idx = np.nonzero(keep)[0]
    bw = np.ceil(np.log2(x1[idx] - x0[idx] + 1)).astype(np.int64)
    bh = np.ceil(np.log2(y1[idx] - y0[idx] + 1)).astype(np.int64)
    frag_pix, frag_face, frag_w, frag_depth = [], [], [], []
    for key in np.unique(bw * 64 + bh):
        batch = idx[(bw * 64 + bh) == key]
        kx, ky = 1 << int(key // 64), 1 << int(key % 64)
        ox, oy = np.meshgrid(np.arange(kx), np.arange(ky))
        px = (x0[batch, None] + ox.ravel()[None]).astype(np.float32)
        py = (y0[batch, None] + oy.ravel()[None]).astype(np.float32)
        a, b, c = (tri[batch, i, :, None] for i in range(3))
        area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        area = np.where(area == 0, np.float32(np.nan), area)
        w1 = ((px - a[:, 0]) * (c[:, 1] - a[:, 1]) - (py - a[:, 1]) * (c[:, 0] - a[:, 0])) / area
        w2 = ((b[:, 0] - a[:, 0]) * (py - a[:, 1]) - (b[:, 1] - a[:, 1]) * (px - a[:, 0])) / area
        w0 = np.float32(1) - w1 - w2
        inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0) & (px <= x1[batch, None]) & (py <= y1[batch, None])
        rows, cols = np.nonzero(inside)
        face = batch[rows]
        w = np.stack([w0[rows, cols], w1[rows, cols], w2[rows, cols]], 1).astype(np.float32)
        frag_pix.append((y0[face] + oy.ravel()[cols]) * width + x0[face] + ox.ravel()[cols])
        frag_face.append(face)
        frag_w.append(w)
        frag_depth.append((w * depth[faces[face]]).sum(1))
    face_at = np.full(width * height, -1, np.int64)
    weights = np.zeros((width * height, 3), np.float32)
    if not frag_pix:
        return face_at, weights
    pix, face, w, near = (np.concatenate(f) for f in (frag_pix, frag_face, frag_w, frag_depth))
    # float32 throughout: the winner test compares each depth with the buffer's copy of it, exactly.
    best = np.full(width * height, -np.inf, np.float32)
    np.maximum.at(best, pix, near)
    win = near >= best[pix]
    face_at[pix[win]], weights[pix[win]] = face[win], w[win]
    return face_at, weights


def _scale_bar(image: np.ndarray, px_per_mm: float) -> None:
    """A bar of a round length (1, 2 or 5 x 10^k mm, about a fifth of the width) at the bottom left."""
    height, width = image.shape[:2]
    target = width * 0.2 / px_per_mm
    power = 10 ** np.floor(np.log10(target))
    length = max(m * power for m in (1, 2, 5) if m * power <= target)
    bar = int(round(length * px_per_mm))
    text = f"{length:g} mm"
    scale = max(width / 900, 0.4) * 1.05  # about 6 pt when the picture is printed half a page wide
    thick = max(2, round(width / 450))
    (tw, th), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, thick)
    x0, y0 = int(width * 0.04), height - int(height * 0.05)
    cv2.rectangle(image, (x0 - 8, y0 - th - 22), (x0 + max(bar, tw) + 8, y0 + 10), (255, 255, 255), -1)
    cv2.rectangle(image, (x0, y0 - 4), (x0 + bar, y0 + 4), (0, 0, 0), -1)
    for x in (x0, x0 + bar):
        cv2.line(image, (x, y0 - 8), (x, y0 + 8), (0, 0, 0), 2)
    cv2.putText(image, text, (x0, y0 - 14), cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), thick, cv2.LINE_AA)


def render_surface(
    npz_path: Path,
    width: int = 900,
    height: int = 700,
    *,
    scaled: bool = False,
    mesh_ply: Path | None = None,
    paint_opacity: float = PAINT_OPACITY,
) -> np.ndarray:
    """The burn surface as an H x W x 3 uint8 RGB picture on white.

    `scaled`: the analysis is in mm (status ok, not unscaled): a scale bar in mm is drawn; otherwise none.
    `mesh_ply`: the reconstructed mesh for the skin's colours; by default mesh/surface.ply of the analysis folder
    that holds surface/burn_surface.npz. `paint_opacity`: the paint's opacity where q >= 0.7 (burn_surface.glb
    uses 0.8)."""
    try:
        data = np.load(npz_path)
        vertices, faces, q = data["vertices"].astype(np.float64), data["faces"].astype(np.int64), data["q"]
    except (OSError, KeyError, ValueError) as exc:
        raise InvalidInput(f"{npz_path} is missing or unreadable ({exc}); run the analysis again") from exc
    if len(faces) == 0 or len(q) != len(vertices):
        raise InvalidInput(f"{npz_path} holds no usable surface; run the analysis again")
    mesh_ply = npz_path.parent.parent / "mesh" / "surface.ply" if mesh_ply is None else mesh_ply
    colours, ply_normals = _skin(vertices, mesh_ply)
    q = np.nan_to_num(q.astype(np.float64))
    burn = q >= 0.5
    face_n, normals = vertex_normals(vertices, faces)
    basis = view_basis(face_n, faces, burn, ply_normals, scaled)
    cam = vertices @ basis.T
    centre, px_per_unit = _frame(cam[:, :2], burn, width, height)
    xy = np.stack(
        [(cam[:, 0] - centre[0]) * px_per_unit + width / 2, (centre[1] - cam[:, 1]) * px_per_unit + height / 2], 1
    )
    face_at, weights = rasterise(xy, cam[:, 2], faces, width, height)

    alpha = (np.clip((q - 0.3) / 0.4, 0, 1) * paint_opacity)[:, None]
    light = _unit(basis[2] * 0.85 + basis[1] * 0.4 - basis[0] * 0.3)
    lambert = 0.35 + 0.65 * np.abs(normals @ light)
    shade = ((colours * (1 - alpha) + PAINT * alpha) * lambert[:, None] * 255).astype(np.float32)
    covered = face_at >= 0
    corners = faces[face_at[covered]]
    image = np.full((width * height, 3), BACKGROUND, np.uint8)
    w = weights[covered]
    image[covered] = np.clip(np.einsum("pk,pkc->pc", w, shade[corners]), 0, 255).astype(np.uint8)
    q_pix = np.zeros(width * height, np.float32)
    q_pix[covered] = np.einsum("pk,pk->p", w, q.astype(np.float32)[corners])
    image = image.reshape(height, width, 3)
    inside = (q_pix >= 0.5).reshape(height, width).astype(np.uint8)
    edge = cv2.morphologyEx(inside, cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8)) > 0
    image[edge] = OUTLINE
    if scaled:
        _scale_bar(image, px_per_unit)
    return image


def write_png(image: np.ndarray, path: Path) -> Path:
    """Write an RGB picture as PNG (cv2 writes BGR)."""
    if not cv2.imwrite(str(path), cv2.cvtColor(image, cv2.COLOR_RGB2BGR)):
        raise InvalidInput(f"could not write {path}; check the folder exists and is writable")
    return path
