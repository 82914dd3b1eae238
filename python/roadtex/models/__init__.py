"""Contact models of rubber on a road profile: the INRETS periodic (and finite) model, the von Meier
envelope, Clapp's sub-profile model and closed-form references (the seed's comparisons are in
:mod:`roadtex.comparisons`)."""

from roadtex.models.clapp import ClappResult, clapp
from roadtex.models.contact import contact, contact_many
from roadtex.models.envelopes import von_meier
from roadtex.models.results import ContactBatch, ContactMeasures, ContactResult, contact_measures
from roadtex.models.surface import SurfaceBatch, SurfaceResult, contact_surface, contact_surface_many

__all__ = ["ClappResult", "ContactBatch", "ContactMeasures", "ContactResult", "clapp", "contact", "contact_many",
           "contact_measures", "contact_surface", "contact_surface_many", "SurfaceBatch", "SurfaceResult", "von_meier"]
