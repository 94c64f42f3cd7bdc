"""Burn-center referral: both guidelines judged on the same record.

- referral_aba2022: American Burn Association, Guidelines for Burn Patient Referral, 2022 (two tiers).
  The table must be checked against the current published version by the clinical lead.
- referral_aba2006: ABA/ACS Guidelines for the Operation of Burn Centers, 2006 (the older single list).

The criteria and facts both tables share are in referral_rules.py.
"""

from __future__ import annotations

from processing.clinical.referral_aba2006 import older_guideline
from processing.clinical.referral_aba2022 import current_guideline
from processing.clinical.referral_rules import ReferralInputs
from schemas.clinical_results import ReferralAssessment

__all__ = ["ReferralInputs", "assess_referral"]


def assess_referral(inputs: ReferralInputs) -> ReferralAssessment:
    """Both referral guidelines judged on the same record."""
    return ReferralAssessment(current=current_guideline(inputs), older=older_guideline(inputs))
