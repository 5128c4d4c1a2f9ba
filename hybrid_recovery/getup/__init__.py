"""Getting up from the ground: floor contacts, static feasibility, contact-state moves,
the multi-contact torque QP."""

from hybrid_recovery.getup.contact_qp import ContactQP, ContactQpConfig
from hybrid_recovery.getup.contacts import FLOOR_CONTACTS, FloorContact
from hybrid_recovery.getup.feasibility import FeasibilityConfig, StaticCheck, static_feasibility

__all__ = ["FLOOR_CONTACTS", "ContactQP", "ContactQpConfig", "FeasibilityConfig",
           "FloorContact", "StaticCheck", "static_feasibility"]
