"""Pure clinical calculators: %TBSA (Lund-Browder), BSA, burn fluid plans, referral criteria.

Every function here is pure: it reads schema Structs, returns frozen result Structs, and
raises schemas.errors.InvalidInput (impossible input) or MissingData (needed data absent)
instead of returning None. Nothing here touches the database, the network or the clock:
the time "now" is always an argument (as_of), and so is the clock-skew tolerance.
"""
