"""A photo as a VL Photographic Image (PS3.3 A.32.4). A baseline JPEG (8 bits, Huffman, SOF0) goes in as it came
from the camera, encapsulated under the JPEG Baseline transfer syntax: the pixels are never decoded and coded
again. Anything else (PNG, HEIC, a progressive JPEG) is decoded once and stored uncompressed (RGB)."""

from __future__ import annotations

import io
from dataclasses import dataclass

from pydicom.dataset import Dataset
from pydicom.encaps import encapsulate
from pydicom.uid import ExplicitVRLittleEndian, JPEGBaseline8Bit, VLPhotographicImageStorage

from processing.dicom import anatomy, common, identity
from processing.dicom.inputs import Photo, StudyInput

LOSSY_METHOD = {"image/jpeg": "ISO_10918_1", "image/heic": "ISO_23008_2"}
"""How the camera compressed what was decoded (PS3.3 C.7.6.1.1.5.1); a PNG was never lossy."""


@dataclass(frozen=True)
class JpegFrame:
    rows: int
    columns: int
    components: int
    subsampled: bool
    """The luminance component is sampled more often than the chroma (4:2:2 or 4:2:0)."""


def baseline_frame(data: bytes) -> JpegFrame | None:
    """The frame header of a baseline JPEG (SOF0, 8-bit, 1 or 3 components); None for any other JPEG or bytes that
    are not a JPEG."""
    if data[:2] != b"\xff\xd8":
        return None
    at = 2
    while at + 4 <= len(data):
        if data[at] != 0xFF:
            return None
        marker = data[at + 1]
        if marker == 0xFF:  # fill byte
            at += 1
            continue
        length = int.from_bytes(data[at + 2 : at + 4], "big")
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            if marker != 0xC0 or at + 10 > len(data):
                return None
            precision = data[at + 4]
            rows = int.from_bytes(data[at + 5 : at + 7], "big")
            columns = int.from_bytes(data[at + 7 : at + 9], "big")
            components = data[at + 9]
            if precision != 8 or components not in (1, 3) or not rows or not columns:
                return None
            sampling = data[at + 11] if at + 12 <= len(data) else 0x11
            return JpegFrame(rows, columns, components, subsampled=sampling != 0x11)
        if marker == 0xDA:  # start of scan before any frame header
            return None
        at += 2 + length
    return None


def instance_uid(asset_id: str) -> str:
    return identity.uid("asset", asset_id, "vl-photographic-image")


def photo(study: StudyInput, picture: Photo, number: int) -> Dataset:
    taken = picture.taken_at or study.encounter.time_of_arrival
    frame = baseline_frame(picture.data) if picture.media_type == "image/jpeg" else None
    syntax = JPEGBaseline8Bit if frame else ExplicitVRLittleEndian
    ds = common.dataset(
        study, common.PHOTOS, VLPhotographicImageStorage, instance_uid(picture.asset_id), number, taken, syntax
    )
    ds.ImageType = ["ORIGINAL", "PRIMARY"]
    ds.AcquisitionContextSequence = []
    ds.PatientOrientation = ""
    ds.BurnedInAnnotation = "NO"
    if picture.taken_at is not None:
        ds.AcquisitionDateTime = identity.dt_value(study, picture.taken_at)
    if picture.camera_make:
        ds.Manufacturer = picture.camera_make[:64]
        ds.SoftwareVersions = ""
    if picture.camera_model:
        ds.ManufacturerModelName = picture.camera_model[:64]
    if picture.filename:
        ds.ImageComments = f"Photo {picture.filename[:100]} as taken (asset {picture.asset_id})"
    anatomy.describe_image(ds, study.wound(picture.wound_id))
    if "ImageLaterality" not in ds:
        ds.Laterality = ""  # General Series, Type 2C: the side is not known
    ds.BitsAllocated = ds.BitsStored = 8
    ds.HighBit = 7
    ds.PixelRepresentation = 0
    if frame:
        ds.Rows, ds.Columns, ds.SamplesPerPixel = frame.rows, frame.columns, frame.components
        if frame.components == 3:
            ds.PhotometricInterpretation = "YBR_FULL_422" if frame.subsampled else "YBR_FULL"
            ds.PlanarConfiguration = 0
        else:
            ds.PhotometricInterpretation = "MONOCHROME2"
        ds.LossyImageCompression = "01"
        ds.LossyImageCompressionMethod = "ISO_10918_1"
        ds.PixelData = encapsulate([picture.data])
        ds["PixelData"].VR = "OB"
        return ds
    rgb = _decoded(picture)
    ds.Columns, ds.Rows = rgb.size
    ds.SamplesPerPixel = 3
    ds.PhotometricInterpretation = "RGB"
    ds.PlanarConfiguration = 0
    method = LOSSY_METHOD.get(picture.media_type)
    ds.LossyImageCompression = "01" if method else "00"
    if method:
        ds.LossyImageCompressionMethod = method
    ds.PixelData = rgb.tobytes()
    return ds


def _decoded(picture: Photo):
    from PIL import Image

    if picture.media_type == "image/heic":
        import pillow_heif

        pillow_heif.register_heif_opener()
    with Image.open(io.BytesIO(picture.data)) as image:
        return image.convert("RGB")
