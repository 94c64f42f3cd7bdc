"""The parts of an encounter's record: intake, primary and secondary survey, mechanism, fluids."""

from __future__ import annotations

import datetime as dt
import enum
from typing import Annotated

import msgspec

from schemas.base import Id, LongText, Message, Millilitres, ShortText, Timestamp


class Medication(Message):
    name: ShortText
    dose: ShortText | None = None


class Allergy(Message):
    substance: ShortText
    reaction: ShortText | None = None


class TetanusStatus(enum.StrEnum):
    """The older, summary form of the tetanus history, kept as recorded; `tetanus_doses` and the time since the
    last dose are what the wound-management table needs (processing/clinical/tetanus.py reads this one only when
    those are not recorded)."""

    up_to_date = "up_to_date"
    """Last dose within 5 years (burns are tetanus-prone wounds)."""
    not_up_to_date = "not_up_to_date"
    never_immunised = "never_immunised"
    unknown = "unknown"


class TetanusDoses(enum.StrEnum):
    """Doses of tetanus-toxoid-containing vaccine received before this injury (the table's rows)."""

    unknown = "unknown"
    fewer_than_three = "fewer_than_three"
    """None, one or two doses."""
    three_or_more = "three_or_more"


class SocialContext(Message):
    lives_with: ShortText | None = None
    safeguarding_concern: bool = False
    """Suspected non-accidental injury, neglect or abuse."""
    substance_use: bool = False
    needs_rehabilitation_support: bool = False
    """Special social, emotional or long-term rehabilitative needs."""
    notes: LongText = ""


class Intake(Message):
    encounter_id: Id
    history_of_present_illness: LongText = ""
    past_medical_history: LongText = ""
    significant_comorbidities: list[ShortText] = []
    """Conditions that could complicate management, prolong recovery or affect mortality."""
    medications: list[Medication] = []
    allergies: list[Allergy] = []
    no_known_allergies: bool = False
    tetanus_status: TetanusStatus = TetanusStatus.unknown
    """The older summary of the tetanus history, kept as recorded: the number of tetanus vaccine doses and the date
    of the last dose are asked for instead."""
    tetanus_doses: TetanusDoses = TetanusDoses.unknown
    """Doses of tetanus vaccine the patient has had in their life, before this burn; "Unknown" if they cannot say."""
    last_tetanus_dose: dt.date | None = None
    """Date of the last dose of a tetanus vaccine (any vaccine with tetanus toxoid), when known."""
    years_since_last_tetanus_dose: Annotated[float, msgspec.Meta(ge=0, le=130)] | None = None
    """When only roughly how long ago is known ("about 10 years ago"): the years since the last tetanus dose. Give
    this or the date of the last dose, not both."""
    severe_immunodeficiency: bool | None = None
    """HIV infection or other severe immunodeficiency: changes the tetanus immune globulin advice."""
    social: SocialContext = msgspec.field(default_factory=SocialContext)


class AirwayIntervention(enum.StrEnum):
    none = "none"
    adjunct = "adjunct"
    intubated = "intubated"
    surgical_airway = "surgical_airway"


class Airway(Message):
    patent: bool | None = None
    facial_burns: bool = False
    singed_nasal_hair: bool = False
    carbonaceous_sputum: bool = False
    soot_in_mouth_or_nose: bool = False
    hoarse_voice: bool = False
    stridor: bool = False
    oropharyngeal_oedema: bool = False
    intervention: AirwayIntervention = AirwayIntervention.none
    cervical_spine_protected: bool | None = None


class Breathing(Message):
    respiratory_rate_per_min: Annotated[int, msgspec.Meta(ge=0, le=90)] | None = None
    spo2_percent: Annotated[int, msgspec.Meta(ge=0, le=100)] | None = None
    oxygen_l_per_min: Annotated[float, msgspec.Meta(ge=0, le=60)] | None = None
    carboxyhaemoglobin_percent: Annotated[float, msgspec.Meta(ge=0, le=100)] | None = None
    circumferential_chest_burn: bool = False
    chest_movement_restricted: bool | None = None
    """The burn restricts the chest's movement: shallow breathing, difficulty breathing, or rising ventilation
    pressures (an escharotomy sign)."""
    breath_sounds: ShortText = ""


class Circulation(Message):
    heart_rate_per_min: Annotated[int, msgspec.Meta(ge=0, le=300)] | None = None
    systolic_bp_mmhg: Annotated[int, msgspec.Meta(ge=0, le=300)] | None = None
    diastolic_bp_mmhg: Annotated[int, msgspec.Meta(ge=0, le=250)] | None = None
    capillary_refill_s: Annotated[float, msgspec.Meta(ge=0, le=30)] | None = None
    iv_access: bool = False
    circumferential_limb_burn: bool = False
    distal_pulses_present: bool | None = None


class Avpu(enum.StrEnum):
    alert = "alert"
    voice = "voice"
    pain = "pain"
    unresponsive = "unresponsive"


class Disability(Message):
    gcs_eye: Annotated[int, msgspec.Meta(ge=1, le=4)] | None = None
    gcs_verbal: Annotated[int, msgspec.Meta(ge=1, le=5)] | None = None
    gcs_motor: Annotated[int, msgspec.Meta(ge=1, le=6)] | None = None
    avpu: Avpu | None = None
    pupils: ShortText = ""
    blood_glucose_mmol_l: Annotated[float, msgspec.Meta(ge=0, le=60)] | None = None


class Exposure(Message):
    temperature_c: Annotated[float, msgspec.Meta(ge=20, le=45)] | None = None
    burn_cooled: bool | None = None
    cooling_minutes: Annotated[float, msgspec.Meta(ge=0, le=240)] | None = None
    jewellery_removed: bool | None = None
    kept_warm: bool | None = None


class PrimarySurvey(Message):
    """ABCDE as recorded by a burn clinician at the bedside."""

    encounter_id: Id
    assessed_at: Timestamp
    airway: Airway = msgspec.field(default_factory=Airway)
    breathing: Breathing = msgspec.field(default_factory=Breathing)
    circulation: Circulation = msgspec.field(default_factory=Circulation)
    disability: Disability = msgspec.field(default_factory=Disability)
    exposure: Exposure = msgspec.field(default_factory=Exposure)
    pain_poorly_controlled: bool | None = None
    """Pain not controlled with the analgesia available here (an ABA 2022 referral criterion)."""


class BodyArea(enum.StrEnum):
    head = "head"
    face = "face"
    eyes = "eyes"
    ears = "ears"
    neck = "neck"
    chest = "chest"
    abdomen = "abdomen"
    back = "back"
    pelvis = "pelvis"
    perineum = "perineum"
    upper_limb_right = "upper_limb_right"
    upper_limb_left = "upper_limb_left"
    hand_right = "hand_right"
    hand_left = "hand_left"
    lower_limb_right = "lower_limb_right"
    lower_limb_left = "lower_limb_left"
    foot_right = "foot_right"
    foot_left = "foot_left"


class Finding(Message):
    area: BodyArea
    finding: LongText


class OtherInjury(Message):
    description: LongText
    area: BodyArea | None = None
    major: bool = False
    """A major injury besides the burn (a fracture, for example): concomitant trauma for the referral criteria."""


class SecondarySurvey(Message):
    """Head-to-toe findings and injuries other than the burn."""

    encounter_id: Id
    assessed_at: Timestamp
    findings: list[Finding] = []
    other_injuries: list[OtherInjury] = []
    burn_poses_greatest_risk: bool | None = None
    """When there are other injuries as well as the burn: whether the burn poses the greatest risk to the patient
    (an older ABA referral criterion)."""
    notes: LongText = ""


class MechanismType(enum.StrEnum):
    flame = "flame"
    scald = "scald"
    contact = "contact"
    chemical = "chemical"
    electrical_low_voltage = "electrical_low_voltage"
    """Below 1000 V."""
    electrical_high_voltage = "electrical_high_voltage"
    """1000 V or more."""
    lightning = "lightning"
    radiation = "radiation"
    friction = "friction"


class Mechanism(Message):
    encounter_id: Id
    type: MechanismType
    """Low-voltage electrical: below 1000 volts; high-voltage: 1000 volts or more."""
    enclosed_space: bool = False
    duration_s: Annotated[float, msgspec.Meta(ge=0, le=86_400)] | None = None
    """How long the exposure lasted, in seconds."""
    agent: ShortText | None = None
    """The liquid, chemical, object or source."""
    voltage_v: Annotated[float, msgspec.Meta(ge=0, le=2_000_000)] | None = None
    explosion: bool = False
    description: LongText = ""
    account_fits_injury: bool | None = None
    """Whether the account of how it happened fits the burn seen (its pattern, depth and site, and the child's
    stage of development). Leave as not recorded if not judged."""
    child_independently_mobile: bool | None = None
    """For a child: whether they can move about on their own (crawl, walk). Leave as not recorded if not judged or
    not a child."""
    pattern_of_concern: bool | None = None
    """A burn pattern that needs an explanation: the shape of an object (cigarette, iron), signs of forced immersion
    (sharp, symmetrical upper limits), or a site not expected to touch a hot object by accident (the backs of the
    hands, the soles, the buttocks, the back). Leave as not recorded if not judged."""


class FluidFormula(enum.StrEnum):
    parkland = "parkland"
    """4 mL x kg x %TBSA (the seed's formula)."""
    abls = "abls"
    """ABLS 2018: 2 mL adult thermal/chemical, 3 mL child, 4 mL high-voltage electrical."""
    custom = "custom"


class FluidGiven(Message):
    volume_ml: Millilitres
    given_at: Timestamp
    fluid: ShortText = "Ringer's lactate"


class Resuscitation(Message):
    """How this encounter's fluids are calculated, and crystalloid already given."""

    encounter_id: Id
    formula: FluidFormula = FluidFormula.parkland
    custom_ml_per_kg_per_percent: Annotated[float, msgspec.Meta(gt=0, le=8)] | None = None
    """With a custom formula only: millilitres of fluid per kilogram of body weight per % of body surface burned."""
    fluid_given: list[FluidGiven] = []
    """Crystalloid already given: how much, when and which fluid."""
