"""Typed configuration: every setting burnedge reads, in one place, each documented.

Loaded from a TOML file (`burnedge --config FILE`), then overridden by environment
variables named BURNEDGE_<SECTION>_<FIELD> (e.g. BURNEDGE_GATEWAY_PORT=8443; lists
comma-separated), then by command-line flags.
"""

from __future__ import annotations

import os
import tomllib
import zoneinfo
from pathlib import Path
from typing import Annotated, Literal

import msgspec

from schemas.base import Message
from schemas.dicom import PatientIdRule
from schemas.errors import InvalidInput


class GatewayConfig(Message):
    host: str = "127.0.0.1"
    """Address to listen on. Use 0.0.0.0 to let phones on the clinic network connect."""
    port: Annotated[int, msgspec.Meta(ge=1, le=65535)] = 8080
    """TCP port of the HTTP API (and of the pages)."""
    https: Literal["auto", "on", "off"] = "auto"
    """HTTPS with the gateway's own certificate authority (docs/security.md): 'auto' serves it when `host` is not
    loopback (phones need it for the camera and offline use), 'on' always, 'off' never. Plain HTTP then answers
    loopback as before, gives other machines the authority's certificate and the phone setup page, and redirects
    the rest to HTTPS."""
    https_port: Annotated[int, msgspec.Meta(ge=1, le=65535)] = 8443
    """TCP port of HTTPS."""
    tls_names: list[str] = msgspec.field(default_factory=list)
    """Extra host names or addresses the certificate names (its own host name and addresses are always in)."""
    database: str = "burnedge.sqlite3"
    """Path of the SQLite database file (created if missing)."""
    sqlite_synchronous: Literal["FULL", "NORMAL"] = "FULL"
    """FULL survives power cuts without losing a committed write; NORMAL is faster and may lose the last commits."""
    busy_timeout_ms: Annotated[int, msgspec.Meta(ge=0)] = 10_000
    """How long a writer waits for another writer before reporting storage busy."""
    page_max: Annotated[int, msgspec.Meta(ge=1)] = 500
    """Largest page a client may ask for (record lists and the change feed); larger requests get this many."""
    max_body_bytes: Annotated[int, msgspec.Meta(ge=1024)] = 32 * 1024 * 1024
    """Largest JSON request body; a full sync push of 1000 mutations fits in the default."""
    clock_skew_s: Annotated[int, msgspec.Meta(ge=0)] = 300
    """Tolerance for clinical times slightly in the future (phone clocks drift)."""
    timezone: str = ""
    """The clinic's time zone, an IANA name such as 'Africa/Nairobi'; empty: this machine's own zone. The pages
    show times in it, name it beside every date-time field, and read a typed time as clinic wall time (stored in
    UTC)."""
    phone_app_dir: str = ""
    """Folder of the phone app's files (index.html, sw.js, js/, …); empty: the ones this version ships
    (gateway/phones/app). Point it at a translated or locally changed copy: phones take the change as an app update
    on their next visit, and nothing waiting on them is lost."""

    def __post_init__(self) -> None:
        if self.phone_app_dir and not all(
            (Path(self.phone_app_dir) / name).is_file() for name in ("index.html", "sw.js")
        ):
            raise msgspec.ValidationError(
                f"phone_app_dir {self.phone_app_dir!r} has no index.html and sw.js: point it at a copy of"
                " gateway/phones/app, or leave it empty for the app this version ships"
            )
        if self.https_port == self.port and self.https != "off":
            raise msgspec.ValidationError(f"https_port {self.https_port} is the HTTP port: give HTTPS its own port")
        if self.timezone:
            try:
                zoneinfo.ZoneInfo(self.timezone)
            except (zoneinfo.ZoneInfoNotFoundError, ValueError) as exc:
                raise msgspec.ValidationError(
                    f"timezone {self.timezone!r} is not a time zone name: use an IANA name such as 'Africa/Nairobi'"
                    " (the list: timedatectl list-timezones), or leave it empty for this machine's zone"
                ) from exc


class SecurityConfig(Message):
    session_ttl_s: Annotated[int, msgspec.Meta(ge=60)] = 12 * 3600
    """Lifetime of a login session (one clinical shift by default)."""
    pairing_code_ttl_s: Annotated[int, msgspec.Meta(ge=30)] = 600
    """How long an unused one-time pairing code stays valid."""
    cookie_secure: bool = False
    """Mark the pages' session cookie Secure: set it when browsers reach the server over HTTPS (a TLS proxy in
    front); over plain HTTP on the clinic's Wi-Fi a Secure cookie would never be sent back."""
    paired_device_roles: list[Literal["clinician", "nurse", "admin", "consultant"]] = []
    """Roles that may log in only from a paired phone (X-Device-Token); empty lets every role use a workstation."""
    argon2_time_cost: Annotated[int, msgspec.Meta(ge=1)] = 3
    """Argon2id iterations."""
    argon2_memory_kib: Annotated[int, msgspec.Meta(ge=8)] = 65_536
    """Argon2id memory per hash in KiB (64 MiB: memory-hard yet fine on a 2-core mini-PC)."""
    argon2_parallelism: Annotated[int, msgspec.Meta(ge=1)] = 2
    """Argon2id lanes."""
    argon2_max_concurrent: Annotated[int, msgspec.Meta(ge=1)] = 2
    """Password hashes computed at once; more logins wait (bounds CPU and memory under a login flood)."""
    login_free_failures: Annotated[int, msgspec.Meta(ge=1)] = 5
    """Failed logins allowed per account or address in the window before slowing down."""
    login_failure_window_s: Annotated[int, msgspec.Meta(ge=1)] = 900
    """A key's count of failed attempts is forgotten after this long without a new attempt."""
    login_base_delay_s: Annotated[int, msgspec.Meta(ge=1)] = 2
    """First lock-out after the free failures; doubles with each further failure."""
    login_max_delay_s: Annotated[int, msgspec.Meta(ge=1)] = 900
    """Longest lock-out."""

    def __post_init__(self) -> None:
        if self.argon2_memory_kib < 8 * self.argon2_parallelism:
            raise ValueError("argon2_memory_kib must be at least 8 x argon2_parallelism")


class ClinicalConfig(Message):
    child_max_age_years: float = 14.0
    """Patients of at most this many completed years are children (ABLS/ABA "14 years or younger": until the 15th birthday)."""
    child_max_weight_kg: float = 30.0
    """Patients below this weight are treated as children too (ABA 2022: <30 kg)."""
    formal_resuscitation_adult_percent: float = 20.0
    """%TBSA from which an adult needs formal fluid resuscitation (ABLS)."""
    formal_resuscitation_child_percent: float = 10.0
    """%TBSA from which a child needs formal fluid resuscitation (ABLS)."""


class UploadConfig(Message):
    """Resumable uploads of photos and videos (the tus protocol)."""

    data_dir: str = ""
    """Folder for uploads in progress and stored media; empty means "burnedge-media" beside the database."""
    max_upload_bytes: Annotated[int, msgspec.Meta(ge=1)] = 2 * 1024**3
    """Largest photo or video accepted, in bytes (a 1-minute 4K phone video is about 400 MB)."""
    expiry_s: Annotated[int, msgspec.Meta(ge=60)] = 24 * 3600
    """An unfinished upload is dropped after this long without completion."""
    min_free_bytes: Annotated[int, msgspec.Meta(ge=0)] = 1024**3
    """Refuse a new upload that would leave less than this much free disk (the database needs room too)."""
    max_video_seconds: Annotated[float, msgspec.Meta(gt=0)] = 600.0
    """Longer videos are refused: an orbit around a burn takes well under a minute, and frame extraction
    decodes every frame on the gateway's two cores."""
    max_photo_bytes: Annotated[int, msgspec.Meta(ge=1)] = 64 * 1024**2
    """Largest photo (phones write 2-30 MB; a photo is decoded in memory, a video is not)."""
    max_open_per_user: Annotated[int, msgspec.Meta(ge=1)] = 50
    """Unfinished uploads one user may hold at once (abandoned ones reserve disk until they expire)."""
    receive_timeout_s: Annotated[float, msgspec.Meta(gt=0)] = 60.0
    """A PATCH that sends nothing for this long is treated as a dropped connection, so the upload can resume."""
    housekeeping_every_s: Annotated[int, msgspec.Meta(ge=10)] = 600
    """How often finished-but-unrecorded uploads are completed and expired ones dropped."""


class QualityGateConfig(Message):
    """Thresholds of the instant quality gate; how they were calibrated: docs/quality-gate.md."""

    min_width: Annotated[int, msgspec.Meta(ge=1)] = 800
    """Smallest long side in pixels (landscape or portrait)."""
    min_height: Annotated[int, msgspec.Meta(ge=1)] = 600
    """Smallest short side in pixels."""
    max_pixels: Annotated[int, msgspec.Meta(ge=1)] = 52_000_000
    """Larger images are refused from their header, before any decoding (decompression bombs). 52 MP covers the
    12, 48 and 50 MP modes phones shoot by default (8160 x 6120 is 49.9 MP); a 200 MP mode is refused with advice."""
    analysis_long_side: Annotated[int, msgspec.Meta(ge=256)] = 1000
    """Images are analysed at this long side so thresholds do not depend on resolution."""
    min_local_sharpness: Annotated[float, msgspec.Meta(ge=0)] = 200.0
    """Below this central-region Laplacian variance a picture is blurry."""
    dark_level: Annotated[int, msgspec.Meta(ge=0, le=255)] = 10
    """Grey level at or below which a pixel counts as clipped dark."""
    bright_level: Annotated[int, msgspec.Meta(ge=0, le=255)] = 245
    """Grey level at or above which a pixel counts as clipped bright."""
    min_mean_intensity: Annotated[float, msgspec.Meta(ge=0, le=255)] = 75.0
    """Below this mean grey level a picture is too dark."""
    max_mean_intensity: Annotated[float, msgspec.Meta(ge=0, le=255)] = 185.0
    """Above this mean grey level a picture is too bright."""
    max_dark_fraction: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.25
    """Above this share of clipped dark pixels a picture is too dark."""
    max_bright_fraction: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.10
    """Above this share of clipped bright pixels a picture is too bright."""
    marker_dictionary: str = "DICT_4X4_50"
    """ArUco dictionary of the printed scale marker (an OpenCV name)."""
    marker_side_mm: Annotated[float, msgspec.Meta(gt=0)] = 20.0
    """Printed side length of one marker, in mm."""
    min_marker_side_px: Annotated[float, msgspec.Meta(ge=0)] = 40.0
    """Below this apparent side in full-resolution pixels the marker is too small for a precise scale."""

    def __post_init__(self) -> None:
        if not self.marker_dictionary.startswith("DICT_") or not self.marker_dictionary[5:].replace("_", "").isalnum():
            raise ValueError(
                f"marker_dictionary {self.marker_dictionary!r} is not an OpenCV ArUco name such as DICT_4X4_50"
            )


class FramesConfig(Message):
    """Turning a video into a multi-view set of stills."""

    max_frames: Annotated[int, msgspec.Meta(ge=1, le=200)] = 15
    """At most this many frames per video, one per equal slice of its length."""
    sharpness_step: Annotated[int, msgspec.Meta(ge=1, le=16)] = 4
    """Sharpness is measured on every n-th pixel of each frame's luma (cheap, and enough to rank frames)."""
    min_motion_fraction: Annotated[float, msgspec.Meta(ge=0, le=1)] = 0.02
    """A frame that moved less than this share of the image width since the last kept frame..."""
    min_difference: Annotated[float, msgspec.Meta(ge=0)] = 3.0
    """...and differs from it by less than this mean grey level is a near-duplicate, and skipped."""
    jpeg_quality: Annotated[int, msgspec.Meta(ge=50, le=100)] = 92
    """JPEG quality of the stored frames."""
    poll_every_s: Annotated[int, msgspec.Meta(ge=5)] = 60
    """How often videos still without frames are looked for (each video upload also starts this at once)."""


class ReadinessConfig(Message):
    """When an encounter's capture set is ready for 3D analysis."""

    min_views: Annotated[int, msgspec.Meta(ge=1)] = 6
    """Accepted photos or frames needed (the seed's minimum)."""
    recommended_views: Annotated[int, msgspec.Meta(ge=2, le=36)] = 8
    """Views the phone's capture guide asks for, round the burn (its ring has one angle fewer, plus straight on)."""
    min_marker_views: Annotated[int, msgspec.Meta(ge=0)] = 2
    """Accepted views that must show the scale marker."""
    min_spread_deg: Annotated[float, msgspec.Meta(ge=0, le=180)] = 20.0
    """Smallest angle between the most different viewing directions (from the marker poses)."""
    default_focal_35mm: Annotated[float, msgspec.Meta(gt=0)] = 26.0
    """Focal length (35 mm equivalent) assumed when a picture does not say: a phone's main camera."""


class ReconstructionConfig(Message):
    """Turning an accepted multi-view set into a scaled 3D surface (the analysis stages)."""

    min_views: Annotated[int, msgspec.Meta(ge=3)] = 5
    """Fewer usable pictures than this and the analysis stops before SfM, saying so."""
    min_registered_fraction: Annotated[float, msgspec.Meta(gt=0, le=1)] = 0.6
    """SfM must place at least this share of the pictures, or the analysis asks for a retake."""
    sift_max_features: Annotated[int, msgspec.Meta(ge=500, le=32768)] = 8192
    """SIFT keypoints kept per picture."""
    sift_first_octave: Annotated[int, msgspec.Meta(ge=-1, le=1)] = 0
    """-1 doubles each picture before SIFT (4x slower; only worth it for small pictures)."""
    sift_peak_threshold: Annotated[float, msgspec.Meta(gt=0)] = 0.004
    """SIFT contrast threshold; lower than COLMAP's 0.0067 to find enough features on low-texture skin."""
    max_image_size: Annotated[int, msgspec.Meta(ge=0)] = 2400
    """Pictures are read for SIFT at most this many pixels on their long side (0: full size)."""
    guided_matching: bool = False
    """Re-match each verified pair along its epipolar geometry: more matches on weakly textured sets, slower."""
    min_pose_inliers: Annotated[int, msgspec.Meta(ge=6)] = 30
    """Matches a picture needs with the model to be placed (COLMAP's default 30; 15 helps sparse texture)."""
    min_pose_inlier_ratio: Annotated[float, msgspec.Meta(gt=0, le=1)] = 0.25
    """Share of those matches that must fit the pose (COLMAP's default 0.25)."""
    thorough_retry: bool = True
    """When too few pictures are placed, try once more with thorough settings (SIFT on doubled pictures,
    16384 features, guided matching, looser pose thresholds): several times slower, but it rescues
    weakly textured sets."""
    video_overlap: Annotated[int, msgspec.Meta(ge=1, le=50)] = 4
    """Video frames: each frame is matched with this many following frames..."""
    video_loop_candidates: Annotated[int, msgspec.Meta(ge=0, le=20)] = 3
    """...and with this many of the most similar earlier frames (loop closure when the orbit returns)."""
    camera_model: str = "SIMPLE_RADIAL"
    """COLMAP camera model; one camera is shared by all pictures of a set (one phone)."""
    marker_dictionary: str = "DICT_4X4_50"
    """ArUco dictionary of the printed scale marker."""
    marker_side_mm: Annotated[float, msgspec.Meta(gt=0)] = 20.0
    """Printed side length of each marker square, outer black edge to outer black edge."""
    marker_min_views: Annotated[int, msgspec.Meta(ge=2)] = 2
    """A marker corner is triangulated only from at least this many placed pictures."""
    max_scale_spread: Annotated[float, msgspec.Meta(gt=0)] = 0.02
    """Marker edges disagreeing by more than this relative spread make the scale untrustworthy."""
    roi_radius_mm: Annotated[float, msgspec.Meta(gt=0)] = 70.0
    """Dense surface is built within this distance of the point the cameras aim at (and the marker)."""
    stereo_sources: Annotated[int, msgspec.Meta(ge=1, le=8)] = 4
    """Neighbouring pictures compared with each reference picture in multi-view stereo."""
    stereo_planes: Annotated[int, msgspec.Meta(ge=16, le=256)] = 64
    """Depth hypotheses of the coarse plane sweep."""
    stereo_full_resolution: bool = True
    """Refine depth at full resolution (slower, sharper); otherwise stop at half resolution."""
    stereo_min_ncc: Annotated[float, msgspec.Meta(ge=-1, le=1)] = 0.5
    """A depth is kept only where its photo-consistency (NCC) reaches this."""
    fusion_min_views: Annotated[int, msgspec.Meta(ge=1)] = 2
    """A depth must agree with this many other pictures' depth maps to enter the fused cloud."""
    mesh_cell_mm: Annotated[float, msgspec.Meta(gt=0)] = 0.4
    """Finest cell of the Poisson surface, in mm (model units when the scale is unknown)."""
    mesh_density_quantile: Annotated[float, msgspec.Meta(ge=0, lt=1)] = 0.04
    """Surface parts supported by the fewest points (this share) are trimmed away."""
    mesh_threads: Annotated[int, msgspec.Meta(ge=-1, le=64)] = 1
    """Threads of the Poisson meshing (-1: all cores). One: with several, Open3D's PoissonRecon now and then dies
    of SIGSEGV (Open3D issues #6828 and #7229; it did once in the demo); benchmarks/mesh_stress.py counts them."""


class AnalysisConfig(Message):
    """Burn segmentation, carrying it onto the surface, and the burn metrics."""

    model: str = ""
    """ONNX segmentation model; empty uses the one shipped with burnedge (see docs/segmentation-model.md)."""
    threads: Annotated[int, msgspec.Meta(ge=1, le=64)] = 1
    """CPU threads the model may use per picture (the gateway's other work keeps the second core)."""
    crop_radius_mm: Annotated[float, msgspec.Meta(gt=0)] = 45.0
    """The model looks at a square of this half-side around the point the cameras aim at (the burn), as it was
    trained; `burnedge segment` on loose photos shows it the whole picture."""
    fusion_rule: Literal["weighted_mean", "log_odds", "noisy_or"] = "weighted_mean"
    """How views' probabilities are combined per surface point (benchmarks/analysis_accuracy.py compares them)."""
    min_views_for_confidence: Annotated[int, msgspec.Meta(ge=1)] = 3
    """A burn surface point is well observed when at least this many pictures see it."""
    ring_inner_mm: Annotated[float, msgspec.Meta(ge=0)] = 3.0
    """Healthy-skin ring for the relief reference starts this far outside the burn edge..."""
    ring_outer_mm: Annotated[float, msgspec.Meta(gt=0)] = 15.0
    """...and ends this far outside it."""
    provisional_hours: Annotated[float, msgspec.Meta(ge=0)] = 72.0
    """Results from pictures taken sooner than this after the injury are marked provisional (burns evolve)."""
    camera_time_zone: str = ""
    """Time zone of the phones' clocks, for EXIF times that carry no offset (an IANA name such as
    'Africa/Nairobi'; empty: this machine's own time zone). The hours since injury count to when the pictures
    were taken."""

    def __post_init__(self) -> None:
        if self.camera_time_zone:
            try:
                zoneinfo.ZoneInfo(self.camera_time_zone)
            except (zoneinfo.ZoneInfoNotFoundError, ValueError) as exc:
                raise msgspec.ValidationError(
                    f"camera_time_zone {self.camera_time_zone!r} is not a time zone name (e.g. 'Europe/Paris')"
                ) from exc
        if self.ring_inner_mm >= self.ring_outer_mm:
            raise msgspec.ValidationError(
                f"ring_inner_mm ({self.ring_inner_mm}) must be less than ring_outer_mm ({self.ring_outer_mm})"
            )


class JobsConfig(Message):
    """The gateway's durable analysis queue and its worker processes."""

    workers: Annotated[int, msgspec.Meta(ge=0, le=16)] = 1
    """Worker processes `burnedge serve` starts for analyses (0: none here; run `burnedge worker` apart).
    One suits a 2-core mini-PC: a reconstruction keeps both cores busy."""
    nice: Annotated[int, msgspec.Meta(ge=0, le=19)] = 10
    """Niceness added to workers, so the API answers first while a reconstruction runs."""
    log_file: str = ""
    """Workers and their analyses write their output here (COLMAP's included); empty: to the gateway's output."""
    work_dir: str = ""
    """Folder of the analyses' work folders; empty means "burnedge-analyses" beside the database."""
    lease_s: Annotated[float, msgspec.Meta(gt=0)] = 60.0
    """A running job belongs to its worker this long after the last heartbeat; a worker that died (killed,
    power cut) loses it then and the job is queued again."""
    heartbeat_s: Annotated[float, msgspec.Meta(gt=0)] = 5.0
    """How often a worker renews its lease and looks for a cancel request."""
    poll_s: Annotated[float, msgspec.Meta(gt=0)] = 2.0
    """How often an idle worker looks for a queued job."""
    max_run_s: Annotated[float, msgspec.Meta(gt=0)] = 3 * 3600.0
    """A try still running after this long is taken as hung (a native library stuck): it is stopped and retried,
    so one stuck analysis cannot hold the queue (a 12-view analysis takes about 2 minutes on 2 cores)."""
    max_attempts: Annotated[int, msgspec.Meta(ge=1, le=20)] = 3
    """Tries of a job that crashed or whose worker died before it is marked failed (with the last reason)."""
    retry_base_s: Annotated[float, msgspec.Meta(ge=0)] = 30.0
    """Wait before the second try; doubled for each further one, with up to 20 % random jitter."""
    retry_max_s: Annotated[float, msgspec.Meta(ge=0)] = 900.0
    """Longest wait between tries."""
    reap_every_s: Annotated[int, msgspec.Meta(ge=1)] = 10
    """How often the gateway requeues jobs whose lease ran out and restarts dead workers."""
    retention_days: Annotated[float, msgspec.Meta(ge=0)] = 30.0
    """After this many days a finished analysis keeps only its results (analysis.json, meshes, masks, overlays,
    metrics); the copied pictures, COLMAP database and depth maps are removed. Failed and cancelled jobs'
    folders go entirely."""
    cleanup_every_s: Annotated[int, msgspec.Meta(ge=60)] = 3600
    """How often the retention clean-up runs."""

    def __post_init__(self) -> None:
        if self.heartbeat_s >= self.lease_s:
            raise ValueError(f"heartbeat_s ({self.heartbeat_s:g}) must be shorter than lease_s ({self.lease_s:g})")


class TrackingConfig(Message):
    """Healing over time: registering each visit's surface to the first one, and the healing figures.
    How the values were chosen: docs/healing.md."""

    burn_margin_mm: Annotated[float, msgspec.Meta(ge=0)] = 5.0
    """Skin within this distance of the burn (of either visit) is left out: the burn shrinks and flattens, and
    its edge swells."""
    skin_ring_mm: Annotated[float, msgspec.Meta(gt=0)] = 20.0
    """Healthy skin is taken from a ring this wide beyond the margin around the burn (the reconstructed skin
    farther out is seen at grazing angles and the drape comes close)."""
    plane_distance_mm: Annotated[float, msgspec.Meta(gt=0)] = 1.0
    """RANSAC plane fit: points this close to the dominant plane (the drape or table) belong to it."""
    plane_clearance_mm: Annotated[float, msgspec.Meta(ge=0)] = 4.0
    """Points lower than this above the dominant plane are left out: the drape does not move with the limb."""
    voxel_mm: Annotated[float, msgspec.Meta(gt=0)] = 1.0
    """Point spacing for the coarse alignment (FPFH features and RANSAC)."""
    fpfh_radius_mm: Annotated[float, msgspec.Meta(gt=0)] = 5.0
    """Neighbourhood radius of the FPFH features."""
    texture_feature_weight: Annotated[float, msgspec.Meta(ge=0)] = 1.0
    """Weight of the skin-texture descriptor next to FPFH in the coarse matching (0: shape only). On the
    near-cylindrical phantom forearms shape alone found the right alignment in 4-5 of 10 RANSAC tries, with
    texture in 10 of 10."""
    ransac_distance_mm: Annotated[float, msgspec.Meta(gt=0)] = 1.5
    """RANSAC: a feature match is an inlier when its points land this close."""
    ransac_iterations: Annotated[int, msgspec.Meta(ge=1000)] = 100_000
    """RANSAC iterations per try."""
    ransac_tries: Annotated[int, msgspec.Meta(ge=1, le=20)] = 5
    """Independent RANSAC tries (seeds seed, seed+1, ...), each refined by ICP; the one whose skin texture agrees
    best wins (then the one matching most skin). A limb is nearly a cylinder: single tries may land on a turned or
    slid copy of it."""
    seed: int = 0
    """Seed of the first RANSAC try, so a rerun gives the same transform."""
    fine_voxel_mm: Annotated[float, msgspec.Meta(gt=0)] = 0.5
    """Point spacing for the ICP refinement."""
    icp_distances_mm: list[float] = msgspec.field(default_factory=lambda: [3.0, 1.5, 0.8])
    """ICP rounds, each with this largest correspondence distance (coarse to fine); the last one also defines
    the overlap and the RMSE reported."""
    point_to_plane: bool = True
    """Point-to-plane ICP (converges on smooth skin where point-to-point slides); false: point-to-point."""
    max_rmse_mm: Annotated[float, msgspec.Meta(gt=0)] = 0.3
    """Above this RMSE (distance of the visit's healthy skin from the first visit's surface, along its normals) the
    registration is flagged as poor; right alignments gave 0.05-0.08 mm on the phantoms."""
    min_overlap: Annotated[float, msgspec.Meta(gt=0, le=1)] = 0.4
    """Below this share of the visit's healthy-skin points matched on the first visit's surface, the
    registration is flagged as poor (a different body part, or too little skin around the burn)."""
    min_texture_agreement: Annotated[float, msgspec.Meta(ge=-1, le=1)] = 0.2
    """Below this correlation of the skin's texture (averaged over ~1 mm) between matched points the registration
    is flagged: on the test's forearm series right alignments read 0.39-0.76 and alignments 6-19 mm off within
    ±0.13. Lighting, hair growth and dressings lower it on real skin."""
    max_burn_shift_mm: Annotated[float, msgspec.Meta(gt=0)] = 15.0
    """A registration that moves the burn's centre by more than this on the skin is flagged as doubtful (burns
    contract towards their centre; they do not wander)."""
    min_points: Annotated[int, msgspec.Meta(ge=10)] = 300
    """Fewer healthy-skin points (at the coarse spacing) than this and the visit is not registered."""
    stall_reduction_percent: Annotated[float, msgspec.Meta(ge=0, le=100)] = 40.0
    """Prompt for review when the area has shrunk by less than this share..."""
    stall_after_days: Annotated[float, msgspec.Meta(gt=0)] = 28.0
    """...this many days after the first measured visit (4 weeks, Kantor & Margolis 2000)."""
    healing_deadline_day: Annotated[float, msgspec.Meta(gt=0)] = 21.0
    """Prompt for surgical review when the burn is not healed on this day after the injury (Deitch et al. 1983:
    hypertrophic scarring in 78 % of sites that took longer than 21 days)."""
    healed_area_cm2: Annotated[float, msgspec.Meta(ge=0)] = 0.5
    """A burn measured smaller than this counts as healed for the day-21 prompt (below what the surface
    reconstruction can tell from a few specks)."""

    def __post_init__(self) -> None:
        if not self.icp_distances_mm or min(self.icp_distances_mm) <= 0:
            raise msgspec.ValidationError(
                f"icp_distances_mm must hold one or more positive distances, got {self.icp_distances_mm}"
            )


class SyncConfig(Message):
    """The clinic's side of store-and-forward: cases go to the burn center over Zenoh, advice comes back."""

    enabled: bool = False
    """Run the sender in `burnedge serve`: queued cases are sent and the center's advice fetched whenever a link
    exists. Needs this site's keys (`burnedge keys init`), the center enrolled and `center_endpoints`. Once the
    administrator sets the link on the Burn center page, that setting takes the place of this one and of
    `center_endpoints` (docs/operations.md)."""
    keys_dir: str = ""
    """Folder of this site's keys; empty means "burnedge-keys" beside the database. Back it up: a site that loses
    its keys must be enrolled again at the center."""
    outbox_dir: str = ""
    """Folder of the encrypted chunks waiting to be sent; empty means "burnedge-outbox" beside the database."""
    center_id: str = ""
    """The enrolled center to send to; empty: the one enrolled center."""
    center_endpoints: list[str] = []
    """Zenoh endpoints of the burn center the clinic connects out to, e.g. "tcp/203.0.113.5:7447" or
    "tls/center.example.org:7447" (clinics sit behind NAT: the center never connects in)."""
    zenoh_config: str = ""
    """A Zenoh JSON5 config file (TLS certificates, transport tuning); the endpoints and mode above override it."""
    connect_timeout_s: Annotated[float, msgspec.Meta(gt=0)] = 10.0
    """How long to try to reach the center before counting the round as failed."""
    chunk_kib: Annotated[int, msgspec.Meta(ge=16, le=1024)] = 128
    """Size of the encrypted chunks a bundle is sent in (each one acknowledged)."""
    window_chunks: Annotated[int, msgspec.Meta(ge=1, le=64)] = 8
    """Chunks sent before waiting for the first acknowledgement; keeps a slow link busy."""
    query_timeout_s: Annotated[float, msgspec.Meta(gt=0)] = 120.0
    """How long one request to the center may wait for its answer (a full window must cross a slow link)."""
    interval_s: Annotated[float, msgspec.Meta(gt=0)] = 15.0
    """How often the gateway looks for work to send and fetches the center's advice."""
    retry_base_s: Annotated[float, msgspec.Meta(ge=0)] = 5.0
    """Wait after a failed round; doubled after each further failure, with full random jitter."""
    retry_max_s: Annotated[float, msgspec.Meta(gt=0)] = 600.0
    """Longest wait between rounds after failures."""
    pictures: Annotated[int, msgspec.Meta(ge=0, le=200)] = 24
    """Photos of the encounter sent with a case, first taken first (the analyses' overlays always go)."""
    key_prefix: str = "burnedge"
    """First part of every Zenoh key expression; must match the center's."""


class BackupConfig(Message):
    """Encrypted backups of the whole gateway state (`burnedge backup`, the nightly timer); docs/backup.md."""

    folder: str = ""
    """Folder of the rotated backups that `burnedge backup` without --out writes (the nightly timer); best a disk
    that is not the gateway's own (a USB disk, a network share). Empty: --out or --dir must be given."""
    keep: Annotated[int, msgspec.Meta(ge=1, le=1000)] = 7
    """Backups kept in the folder; the oldest beyond this many are removed after each new one is complete."""
    recipient: str = ""
    """Public key file (from `burnedge backup keygen`) to encrypt to; its private half is kept off the gateway, so
    nothing on the gateway can open its backups. Empty: encrypt to a passphrase."""
    passphrase_file: str = ""
    """File holding the passphrase, when no recipient is set (e.g. a systemd credential); readable by the service
    user only. Empty: --passphrase-file, --passphrase-env or a prompt."""
    kdf_opslimit: Annotated[int, msgspec.Meta(ge=1, le=64)] = 3
    """Argon2id passes deriving the key from a passphrase (libsodium's "moderate")."""
    kdf_memory_kib: Annotated[int, msgspec.Meta(ge=8, le=4 * 1024**2)] = 256 * 1024
    """Argon2id memory in KiB (256 MiB, libsodium's "moderate"); a restore needs as much."""
    chunk_kib: Annotated[int, msgspec.Meta(ge=4, le=65536)] = 1024
    """Plain size of each authenticated chunk of the encrypted stream; memory stays at about this much."""


class CentralConfig(Message):
    """The burn center's server (`burnedge central`)."""

    database: str = "burnedge-central.sqlite3"
    """Database of received cases, consultants' accounts and notes: a SQLite file's path (one worker), or a
    PostgreSQL URL such as "postgresql://burnedge@/burnedge?host=/run/postgresql" (several workers; keep the
    password in ~/.pgpass or PGPASSFILE, not here)."""
    database_connections: Annotated[int, msgspec.Meta(ge=2, le=200)] = 12
    """Most connections a worker opens to PostgreSQL (unused with SQLite); the server's max_connections must hold
    this times the number of workers, plus the command line's."""
    store_dir: str = ""
    """Folder of received bundles' files; empty means "burnedge-central-store" beside the database (required when
    the database is a PostgreSQL URL; every worker must see the same folder)."""
    keys_dir: str = ""
    """Folder of the center's keys; empty means "burnedge-central-keys" beside the database (required when the
    database is a PostgreSQL URL)."""
    listen_endpoints: list[str] = msgspec.field(default_factory=lambda: ["tcp/0.0.0.0:7447"])
    """Zenoh endpoints clinics connect to (use tls/... with certificates in `zenoh_config` on the internet)."""
    zenoh_config: str = ""
    """A Zenoh JSON5 config file (TLS certificates, transport tuning); the endpoints above override it."""
    router_endpoints: list[str] = []
    """Zenoh routers this worker connects to (`burnedge central router`, which listens on listen_endpoints, or a
    standalone zenohd), e.g. "tcp/127.0.0.1:7447". Empty: this process is the router itself and the only worker.
    Workers on the same database, store folder and keys that connect to the same routers share the clinics among
    them and take over a stopped worker's clinics at once."""
    worker_id: Annotated[str, msgspec.Meta(pattern=r"^[A-Za-z0-9._-]{0,64}$")] = ""
    """This worker's name among the center's workers, unique among them (e.g. "center-1"); empty: the host name,
    process id and a random suffix."""
    host: str = "127.0.0.1"
    """Address of the consultants' HTTP API."""
    port: Annotated[int, msgspec.Meta(ge=1, le=65535)] = 8090
    """Port of the consultants' HTTP API."""
    max_bundle_mib: Annotated[int, msgspec.Meta(ge=1)] = 512
    """Largest bundle accepted; larger announcements are rejected with the reason."""
    max_chunk_kib: Annotated[int, msgspec.Meta(ge=16)] = 1024
    """Largest chunk accepted."""
    stale_transfer_days: Annotated[float, msgspec.Meta(gt=0)] = 14.0
    """Chunks of a bundle announced but never completed are removed after this many days."""
    handler_threads: Annotated[int, msgspec.Meta(ge=1, le=32)] = 4
    """Threads answering clinics' requests."""
    key_prefix: str = "burnedge"
    """First part of every Zenoh key expression; must match the clinics'."""


class ReportConfig(Message):
    """The clinical report (PDF) of an encounter."""

    clinic_name: str = ""
    """The clinic's name as the report's header prints it; empty: the encounter's recorded facility."""
    reports_dir: str = ""
    """Folder of the reports made, one file per set of record versions; empty means "burnedge-reports" beside the
    database."""


class DicomConfig(Message):
    """The hospital's PACS: encounters (and, at the burn center, received cases) sent as DICOM studies over
    DICOMweb (STOW-RS, checked with QIDO-RS); docs/dicom.md."""

    endpoint: str = ""
    """The PACS's DICOMweb root, e.g. "https://pacs.example.org/dicom-web" (Orthanc: ".../dicom-web"). Empty: no
    PACS, and the pages offer no "Send to the hospital's PACS" action."""
    username: str = ""
    """HTTP basic authentication user, with `password_file`; empty: no basic authentication."""
    password_file: str = ""
    """File holding the basic-authentication password (one line), readable by the service user only."""
    token_file: str = ""
    """File holding a bearer token (OAuth 2), sent instead of basic authentication when set."""
    ca_file: str = ""
    """CA bundle (PEM) the PACS's HTTPS certificate is checked against; empty: the system's."""
    timeout_s: Annotated[float, msgspec.Meta(gt=0, le=3600)] = 60.0
    """How long one request to the PACS may take (a study of full-size photos is tens of MB)."""
    patient_id_rule: PatientIdRule = PatientIdRule.record_number
    """How the DICOM PatientID is chosen: "record_number" (the clinic's medical record number, else the prefix and
    burnedge's patient id) or "burnedge_id" (always the prefix and burnedge's patient id). Never empty."""
    patient_id_prefix: Annotated[str, msgspec.Meta(max_length=20)] = "BE-"
    """Put before burnedge's patient id when it stands as the PatientID."""
    issuer_of_patient_id: Annotated[str, msgspec.Meta(max_length=64)] = ""
    """IssuerOfPatientID written beside the PatientID (the hospital's name for the clinic's numbering); empty: left
    out."""
    institution_name: Annotated[str, msgspec.Meta(max_length=64)] = ""
    """InstitutionName in every object; empty: [report] clinic_name, else left out."""

    @property
    def configured(self) -> bool:
        return bool(self.endpoint.strip())


class Config(Message):
    gateway: GatewayConfig = msgspec.field(default_factory=GatewayConfig)
    """The HTTP gateway and its database."""
    security: SecurityConfig = msgspec.field(default_factory=SecurityConfig)
    """Sessions, pairing and password hashing."""
    clinical: ClinicalConfig = msgspec.field(default_factory=ClinicalConfig)
    """Thresholds used by the clinical calculators."""
    quality: QualityGateConfig = msgspec.field(default_factory=QualityGateConfig)
    """Thresholds of the instant photo quality gate."""
    uploads: UploadConfig = msgspec.field(default_factory=UploadConfig)
    """Resumable photo and video uploads."""
    frames: FramesConfig = msgspec.field(default_factory=FramesConfig)
    """Frames taken from videos."""
    readiness: ReadinessConfig = msgspec.field(default_factory=ReadinessConfig)
    """When a capture set is ready for 3D analysis."""
    reconstruction: ReconstructionConfig = msgspec.field(default_factory=ReconstructionConfig)
    """SfM, metric scale, multi-view stereo and meshing."""
    analysis: AnalysisConfig = msgspec.field(default_factory=AnalysisConfig)
    """Burn segmentation, mapping onto the surface, and metrics."""
    jobs: JobsConfig = msgspec.field(default_factory=JobsConfig)
    """The analysis queue and its workers."""
    tracking: TrackingConfig = msgspec.field(default_factory=TrackingConfig)
    """Healing over time: registration of each visit to the first, healing rate and review prompts."""
    sync: SyncConfig = msgspec.field(default_factory=SyncConfig)
    """Sending cases to the burn center and receiving its advice (the clinic's side)."""
    central: CentralConfig = msgspec.field(default_factory=CentralConfig)
    """The burn center's server."""
    backup: BackupConfig = msgspec.field(default_factory=BackupConfig)
    """Encrypted backups of the whole gateway state."""
    report: ReportConfig = msgspec.field(default_factory=ReportConfig)
    """The clinical report (PDF) of an encounter."""
    dicom: DicomConfig = msgspec.field(default_factory=DicomConfig)
    """The hospital's PACS (DICOMweb), for the clinic and the burn center."""


def load_config(path: str | Path | None = None, environ: dict[str, str] | None = None) -> Config:
    """Read a TOML file (optional), apply BURNEDGE_* environment overrides, validate."""
    raw: dict = {}
    if path is not None:
        try:
            raw = tomllib.loads(Path(path).read_text())
        except FileNotFoundError as exc:
            raise InvalidInput(f"config file {path} does not exist") from exc
        except tomllib.TOMLDecodeError as exc:
            raise InvalidInput(f"config file {path} is not valid TOML: {exc}") from exc
    env = os.environ if environ is None else environ
    sections = (
        ("gateway", GatewayConfig),
        ("security", SecurityConfig),
        ("clinical", ClinicalConfig),
        ("quality", QualityGateConfig),
        ("uploads", UploadConfig),
        ("frames", FramesConfig),
        ("readiness", ReadinessConfig),
        ("reconstruction", ReconstructionConfig),
        ("analysis", AnalysisConfig),
        ("jobs", JobsConfig),
        ("tracking", TrackingConfig),
        ("sync", SyncConfig),
        ("central", CentralConfig),
        ("backup", BackupConfig),
        ("dicom", DicomConfig),
    )
    for section, struct in sections:
        defaults = struct()
        for field in struct.__struct_fields__:
            value = env.get(f"BURNEDGE_{section}_{field}".upper())
            if value is None:
                continue
            if isinstance(getattr(defaults, field), list):  # lists come comma-separated
                value = [item.strip() for item in value.split(",") if item.strip()]
            raw.setdefault(section, {})[field] = value
    try:
        return msgspec.convert(raw, Config, strict=False)
    except msgspec.ValidationError as exc:
        raise InvalidInput(f"configuration is invalid: {exc}") from exc
