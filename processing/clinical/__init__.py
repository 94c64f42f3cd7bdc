"""Pure clinical calculators: %TBSA (Lund-Browder), BSA, burn fluid plans, referral criteria.

Every function here is pure: it reads schema Structs, returns frozen result Structs, and
raises schemas.errors.InvalidInput (impossible input) or MissingData (needed data absent)
instead of returning None. Nothing here touches the database, the network or the clock,
except fluids.py, which checks that an injury time is not in the real future.
"""
