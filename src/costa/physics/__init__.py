"""The aluminum cell model as a composition of named, replaceable parts."""

from .cell import CellVariables
from .model import BALANCES, BalanceTerm, CellModel, InputCorrection, ablated_model, model_from_config, true_model
from .operating_range import operating_points
from .parameters import (
    CONSTANTS,
    CellParameters,
    MaterialProperties,
    authors_code_parameters,
    constants_table,
    paper_printed_parameters,
    parameters_from_config,
)
from .parts import PART_ORDER, Part, constant_part
from .properties import PROPERTIES, PhysicalProperty, PropertyCorrection

__all__ = [
    "BALANCES",
    "CONSTANTS",
    "PART_ORDER",
    "PROPERTIES",
    "BalanceTerm",
    "CellModel",
    "CellParameters",
    "CellVariables",
    "InputCorrection",
    "MaterialProperties",
    "Part",
    "PhysicalProperty",
    "PropertyCorrection",
    "ablated_model",
    "authors_code_parameters",
    "constant_part",
    "constants_table",
    "model_from_config",
    "operating_points",
    "paper_printed_parameters",
    "parameters_from_config",
    "true_model",
]
