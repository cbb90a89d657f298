"""The TE protocols: campaigns read back, validation on the virtual bench, monitoring (spec 02 §6).

::

    from drivelash.te.protocol import load_campaign, validate, ValidationConfig

    camp = load_campaign(CAMPAIGN_DIR)
    summary = validate(model, camp, OUT_DIR, ValidationConfig.quick())
"""

from drivelash.te.protocol.bench import (
    ValidationConfig,
    compensator_for,
    drive_for_model,
    table_for,
    training_torque_max,
)
from drivelash.te.protocol.campaign import Campaign, CampaignRun, load_campaign
from drivelash.te.protocol.monitoring import MonitorParams, SectionReport, monitor_pass, monitor_sections
from drivelash.te.protocol.passes import run_pass
from drivelash.te.protocol.validate import validate
from drivelash.te.protocol.wear_demo import TreesUpdater

__all__ = [
    "Campaign",
    "CampaignRun",
    "MonitorParams",
    "SectionReport",
    "TreesUpdater",
    "ValidationConfig",
    "compensator_for",
    "drive_for_model",
    "load_campaign",
    "monitor_pass",
    "monitor_sections",
    "run_pass",
    "table_for",
    "training_torque_max",
    "validate",
]
