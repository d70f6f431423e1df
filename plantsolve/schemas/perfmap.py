"""Request and result models of the ``perfmap`` solver (compressor performance maps).

Conventions
-----------
- ``theta`` (inlet guide vane setting) and ``phi`` (diffuser setting) are setting values in
  whatever unit the rig uses (degrees, %, speed fraction…); the solver never mixes them with
  each other: the triangulation of the settings is done on range-normalised values.
- ``flow`` (x), ``pressure`` (y) and ``efficiency`` (eta) are the measured values in the request's
  ``units`` (pint spellings: ``kg/s``, ``lbm/s``, ``m3/h``, ``bar``, ``kPa``, ``psi``, ``%``, ``-`` …; a CSV
  or Excel header's unit, e.g. ``Wc [lbm/s]``, sets them). Results are in the same units, or in
  ``options.result_units`` when given; efficiency is always a fraction. The result's ``units`` states
  which unit each quantity is in.
- A characteristic is parametrised by ``t = (x - x_min) / (x_max - x_min)`` in [0, 1], where
  ``x_min``/``x_max`` are the smallest/largest measured flow of the setting.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Discriminator, Field, RootModel, Tag, field_validator, model_validator

from plantsolve.schemas.common import Diagnostic, FiniteFloat, Flag, Integer, Measured, Number, Report, StrictModel, \
    plain_numbers, unit

# units of result fields (x-unit in the OpenAPI document): placeholders name the result's ``units`` fields
FLOW = unit("{units.flow}")
PRESSURE = unit("{units.pressure}")
ONE = unit("1")
SETTINGS = unit("{units.settings}")
FIRST_SETTING = unit("{units.settings.0}")
SECOND_SETTING = unit("{units.settings.1}")

Family = Literal["parabola", "log", "cubic", "spline2", "spline3", "concave"]
FAMILY_DESCRIPTION = (
    "Curve family. With t = (x - x_min)/(x_max - x_min): "
    "'parabola': y = sum_k c_k B_k^2(t) (Bernstein degree 2, 3 coefficients); "
    "'cubic': y = sum_k c_k B_k^3(t) (cubic Bezier, 4 coefficients); "
    "'spline2'/'spline3': uniform quadratic B-spline with K = 2/3 segments on knots "
    "-2, -1, ..., K+2 in the parameter K*t (K+2 coefficients); "
    "'log': y = a*log(b - x) + c with coefficients [a, b, c], b > x_max, in flow units; "
    "'concave' (beyond the paper): the decreasing concave broken line with a knot at every measured flow, "
    "coefficients [x_1, ..., x_n, y_1, ..., y_n] (knot flows, then pressures); it reaches any data a "
    "decreasing concave curve can."
)

EfficiencyFamily = Literal["parabola", "cubic", "spline2", "spline3", "parabola_log"]
EFFICIENCY_FAMILY_DESCRIPTION = (
    "Efficiency curve family, on the same t: 'parabola', 'cubic', 'spline2', 'spline3' as for "
    "the pressure (coefficients = control values); 'parabola_log' (beyond the paper): "
    "eta = c0 (1-t)^2 + 2 c1 t (1-t) + c2 t^2 + a*log(beta - t) with coefficients "
    "[c0, c1, c2, a, beta], a >= 0, beta > 1 (in t units): the log term follows the steep "
    "efficiency drop at choke, where polynomials overshoot at the peak. Every efficiency "
    "curve satisfies 0 <= eta <= 1 exactly on its whole flow range.")


class Position(StrictModel):
    """Measurements at one setting: one characteristic. The setting is ``setting`` (values in the order of
    the request's ``setting_names``) or, for the paper's two settings, ``theta`` and ``phi``."""

    setting: list[Measured] | None = Field(
        default=None, min_length=1, max_length=3,
        description="Setting values in the order of the request's setting_names (e.g. [speed] or [IGV, speed]).")
    theta: Measured | None = Field(default=None, description="Inlet guide vane setting (rig unit, e.g. degrees).")
    phi: Measured | None = Field(default=None, description="Diffuser setting (rig unit, e.g. degrees).")
    flow: list[Measured] = Field(
        min_length=3, max_length=10_000,
        description="Measured flow x per point (any order; sorted by the solver).")
    # The bounds of each value are stated in the schema and checked by the solver's input check,
    # whose messages name the file row and suggest the fix (a '%' column divided by 100).
    pressure: list[Measured] = Field(
        min_length=3, max_length=10_000,
        json_schema_extra={"items": {"type": "number", "exclusiveMinimum": 0, "maximum": 1e12}},
        description="Measured pressure y per point (same length as flow), positive.")
    efficiency: list[Measured] = Field(
        min_length=3, max_length=10_000,
        json_schema_extra={"items": {"type": "number", "exclusiveMinimum": 0, "maximum": 1}},
        description="Measured efficiency eta per point (same length as flow), a fraction in (0, 1], e.g. 0.85.")


UnitText = Annotated[str, Field(min_length=1, max_length=40)]


class QuantityUnits(StrictModel):
    """Units of the measured quantities (pint spellings as exporters write them). Unset: not stated."""

    flow: UnitText | None = Field(
        default=None, description="Flow unit: a mass flow (kg/s, lbm/s), a volume flow (m3/h, m^3/s, m³/s) or "
        "dimensionless ('-', '1', '%').", examples=["kg/s"])
    pressure: UnitText | None = Field(
        default=None, description="Pressure unit: a pressure (Pa, kPa, bar, psi), a ratio ('-', '1'), a head (m) or "
        "a specific work (J/kg).", examples=["bar"])
    efficiency: UnitText | None = Field(
        default=None, description="Efficiency unit: '-' or '1' (a fraction) or '%' (divided by 100 on input).",
        examples=["%"])


class ResultUnitsOption(StrictModel):
    """Units to give flow and pressure in (converted from the request's units, which must then be stated)."""

    flow: UnitText | None = Field(default=None, examples=["kg/s"])
    pressure: UnitText | None = Field(default=None, examples=["kPa"])


BETA_CONVENTION = (
    "Auxiliary coordinate beta (GasTurb's convention): beta = 0 at the choke end of every speed line (its "
    "largest fitted flow), beta = 1 at its surge end (smallest fitted flow). pyCycle's R-line is "
    "R = 1 + 2 (1 - beta): RlineStall = 1 at surge, R = 3 at choke. Beta lines are Smooth C's family "
    "y - y_v = c (x - x_v)^p through a common vertex (x_v, y_v) (p = 2: 'parabola', p = 1: 'straight'); "
    "on each speed line the node of beta lies where c = c_choke + beta (c_surge - c_choke), c_surge and "
    "c_choke being the values through the line's own ends. When the surge and choke lines are themselves "
    "such curves every beta line is one exactly; otherwise the lines bend to meet every speed line's ends. "
    "c falls strictly along a speed line above the vertex (pressure non-increasing, flow increasing): each "
    "beta line crosses each speed line exactly once.")


MAX_BETA_LINES = 40  # GSP's map table format: at most 40 argument values a table


class BetaGridOption(StrictModel):
    """The auxiliary-coordinate (beta/R-line) grid the fitted map is tabulated on for cycle codes."""

    lines: Integer = Field(default=21, ge=2, le=MAX_BETA_LINES, description="Number of beta lines, from 0 (choke) to 1 "
                           "(surge). At most 40: GSP reads at most 40 argument values in a map table (its 'Map "
                           "table format'), and one grid feeds every export and the (speed, beta) query.")
    spacing: Literal["adaptive", "even"] = Field(
        default="adaptive", description="'adaptive': the beta values (multiples of 0.001, shared by all lines) "
        "are placed where the table read linearly between its nodes, as cycle codes read it, would leave the "
        "fitted lines most (Ramer-Douglas-Peucker splitting): steep choke ends and the kinks of broken-line fits "
        "get nodes. 'even': evenly spaced, as Smooth C writes them. Either way beta_map states how far the "
        "table departs from each line.")

    @field_validator("lines", mode="before")
    @classmethod
    def _within_gsp(cls, value: Any) -> Any:
        # refused rather than capped: the one grid feeds every export and the (speed, beta) query, so a capped
        # GasTurb file would disagree with the others; 40 adaptive lines already bring the table far inside the fit
        if isinstance(value, int) and not isinstance(value, bool) and value > MAX_BETA_LINES:
            raise ValueError(f"at most {MAX_BETA_LINES} beta lines: GSP reads at most {MAX_BETA_LINES} values a map "
                             f"table row (the GasTurb export's beta values); got {value}")
        return value
    shape: Literal["parabola", "straight"] = Field(
        default="parabola", description="Beta lines as parabolas (p = 2) or straight lines (p = 1) "
        "through the vertex. " + BETA_CONVENTION)


class PerfmapOptions(StrictModel):
    _plain_numbers = plain_numbers("surge_margin")

    model: Literal["auto", "parabola", "log", "cubic", "spline2", "spline3", "concave"] = Field(
        default="auto",
        description="Pressure curve family for the characteristics; 'auto' picks the paper family "
        "with the smallest mean (over settings) leave-one-out pressure error, and gives a setting it "
        "misses by more than 1 % above the setting's floor the family that reaches it (smallest "
        "leave-one-out error among those within 1 %, else the smallest error). The efficiency "
        "family is chosen separately (`efficiency_model`). " + FAMILY_DESCRIPTION)
    efficiency_model: Literal["auto", "same", "parabola", "cubic", "spline2", "spline3",
                              "parabola_log"] = Field(
        default="auto",
        description="Efficiency curve family, chosen independently of the pressure family. "
        "'auto': per setting, the family with the smallest leave-one-out max ABSOLUTE "
        "efficiency error (relative errors would be dominated by the small efficiencies at "
        "choke; ties go to fewer coefficients); 'same': the paper's pairing with `model` "
        "(log pressure -> cubic efficiency); or a family name for every setting. "
        + EFFICIENCY_FAMILY_DESCRIPTION)
    fit: Literal["least_squares", "minimax"] = Field(
        default="least_squares",
        description="'least_squares' minimises the sum of squared residuals (paper eq. 3); "
        "'minimax' minimises the maximal relative error directly (linear programme).")
    grid: list[Integer] = Field(
        default_factory=lambda: [64, 64], min_length=2, max_length=2,
        description="Map grid [nx, ny]: nodes along flow and along pressure (2..400 each; the map is stored "
        "with the job).")
    map: Flag | None = Field(
        default=None,
        description="Compute the performance map; it needs >= 3 settings not all on one line "
        "in (theta, phi). null (default): compute it when the settings allow one, otherwise "
        "return characteristics and envelopes with a 'map_not_possible' warning; true: "
        "reject such input (422); false: characteristics and envelopes only.")
    map_method: Literal["exact", "binning"] = Field(
        default="exact",
        description="'exact': per grid node, solve for the barycentric weights of every "
        "(triangle, t) exactly; 'binning': the paper's scatter-and-bin (eqs. 62-71), for "
        "comparison only.")
    t_samples: Integer = Field(
        default=129, ge=3, le=4097,
        description="Number of samples of the curve parameter t in [0, 1] for the map and "
        "the inverse query.")
    envelope_curves: Integer = Field(
        default=50, ge=1, le=2000,
        description="Interpolated curves per pair of neighbouring phi settings used to take "
        "the max-curve (paper section 3, N = 50).")
    envelope_points: Integer = Field(
        default=200, ge=2, le=10_000, description="Flow samples along each envelope.")
    concave_efficiency: Flag = Field(
        default=False, description="Also constrain the efficiency curve to be concave.")
    surge_margin: Number = Field(
        default=0.0, ge=0.0, le=1.0,
        description="Surge margin for the 'surge_margin_line' (0: none): on each characteristic the point whose "
        "pressure is the surge pressure / (1 + margin), i.e. SM = p_surge / p - 1 at constant setting.")
    result_units: ResultUnitsOption | None = Field(
        default=None, description="Convert flow and/or pressure to these units (same dimensions as the request's "
        "units) before solving: the result, its plots and its exports are in them.")
    beta_grid: BetaGridOption = Field(
        default_factory=BetaGridOption,
        description="The beta/R-line grid of the cycle-code exports (map_pycycle.py, map_gasturb.map, "
        "map_beta.csv) and of the (speed, beta) query.")
    sheet: Annotated[str, Field(min_length=1, max_length=100)] | None = Field(
        default=None, description="Excel uploads: the worksheet to read (default: the first sheet with a "
        "recognisable header).")
    columns: dict[str, str] | None = Field(
        default=None,
        description="CSV uploads: header name -> role, for headers the parser does not know (roles: theta, phi, "
        "igv, vgv, alpha, speed, diffuser, flow, pressure, efficiency, rline, ignore). Example: "
        '{"N1 [%]": "speed", "Q [m3/h]": "flow"}.')

    @model_validator(mode="after")
    def _grid_range(self) -> "PerfmapOptions":
        if any(not 2 <= g <= 400 for g in self.grid):
            raise ValueError("grid entries must be between 2 and 400")
        return self


class ValueConversion(StrictModel):
    """One conversion the reader made: value used = value read × factor."""

    quantity: str = Field(max_length=100, description="What was converted: 'flow', 'pressure', 'efficiency' or a "
                          "setting's name.")
    column: str | None = Field(default=None, max_length=200, description="The file's column header (uploads).")
    from_unit: str = Field(max_length=40, description="The unit the values were read in ('%', 'lbm/s', ...).")
    to_unit: str = Field(max_length=40, description="The unit they are used in ('1' for a fraction).")
    factor: Number = Field(gt=0, le=1e12, description="Multiplier from the values read to the values used.")
    basis: Literal["header", "units_row", "cells", "request", "result_units", "values"] = Field(
        description="Where the unit came from: the column header, the row of units under it, the cells themselves "
        "('85.85%', a number format stating a unit), the request's units, options.result_units, or the values "
        "themselves (a header unit they contradict).")


class PerfmapSource(StrictModel):
    """What the upload reader found: set by the upload parser, not needed in JSON bodies."""

    format: Literal["csv", "xlsx", "pycycle", "gasturb", "json"] = Field(description="The format read.")
    row_label: str = Field(default="line", max_length=200,
                           description="How the file's rows are named in messages ('line', \"sheet 'Map' row\").")
    rows: list[list[Integer]] = Field(
        default_factory=list, max_length=2000,
        description="Per position, the file row of each of its points (in the order of its values): what a "
        "refusal of a value names.")
    setting_lines: list[Integer] = Field(
        default_factory=list, max_length=2000,
        description="Per position, the file line that heads its points (a GasTurb/GSP map's speed line in its Mass "
        "Flow table): what a warning about a whole setting line names.")
    conversions: list[ValueConversion] = Field(default_factory=list, max_length=20,
                                              description="Unit conversions the reader made.")
    document: Literal["request", "positions"] | None = Field(
        default=None, description="A JSON upload: the file holds the request, or a bare list of its positions "
        "(a value's place in the file is its request path, less 'positions' for a list).")
    form: dict[str, list[str]] = Field(
        default_factory=dict, max_length=100,
        description="The values the upload form gave ('options.beta_grid', 'units.flow'), each with its place in the "
        "form (['options', 'options', 'beta_grid']): what a refusal of that value names.")


class PerfmapRequest(StrictModel):
    """Rig measurements at several settings and what to compute from them."""

    setting_names: list[str] = Field(
        default_factory=lambda: ["theta", "phi"], min_length=1, max_length=3,
        description="Names of the setting parameters (1 to 3: speed, IGV/VGV angle, diffuser angle, ...); the "
        "paper's case is ['theta', 'phi']. One parameter gives a one-parameter (e.g. speed) map; two or three "
        "the paper's maximum-efficiency map over the settings.")
    setting_units: list[str] | None = Field(
        default=None, description="Unit of each setting parameter (labels only), in the order of setting_names.")
    units: QuantityUnits | None = Field(
        default=None, description="Units of flow, pressure and efficiency as submitted (unset: not stated; "
        "efficiency a fraction).")
    positions: list[Position] = Field(
        min_length=1, max_length=2000,
        description="One entry per setting; settings must be distinct.")
    options: PerfmapOptions = Field(default_factory=PerfmapOptions)
    upload_warnings: list[Diagnostic] = Field(
        default_factory=list, max_length=100,
        description="Notes of the file parser (e.g. ignored CSV columns), repeated in the "
        "result's report; set by the upload parser, not needed in JSON bodies.")
    source: PerfmapSource | None = Field(
        default=None, description="Set by the upload parser: the format read, the file rows of the points and the "
        "unit conversions made (stated again in the result's report.details.source).")

    @model_validator(mode="after")
    def _settings_given(self) -> "PerfmapRequest":
        d = len(self.setting_names)
        if len(set(self.setting_names)) != d:
            raise ValueError("setting_names must be distinct")
        if self.setting_units is not None and len(self.setting_units) != d:
            raise ValueError(f"setting_units needs {d} entries, one per setting name")
        for i, p in enumerate(self.positions):
            if p.setting is not None:
                if len(p.setting) != d:
                    raise ValueError(f"positions[{i}].setting has {len(p.setting)} values; setting_names has {d}")
            elif not (self.setting_names == ["theta", "phi"] and p.theta is not None and p.phi is not None):
                raise ValueError(f"positions[{i}] needs 'setting' ({d} values: {', '.join(self.setting_names)})"
                                 + (" or 'theta' and 'phi'" if self.setting_names == ["theta", "phi"] else ""))
        return self

    def setting_values(self, i: int) -> tuple[float, ...]:
        p = self.positions[i]
        return tuple(p.setting) if p.setting is not None else (float(p.theta), float(p.phi))


class SettingFit(BaseModel):
    """The fitted characteristic y(x) and efficiency eta(x) of one setting."""

    setting: list[float] = Field(default_factory=list, description="Setting values, in the order of setting_names.",
                                 json_schema_extra=SETTINGS)
    theta: float | None = Field(default=None, description="With two setting parameters: the first.",
                                json_schema_extra=FIRST_SETTING)
    phi: float | None = Field(default=None, description="With two setting parameters: the second.",
                              json_schema_extra=SECOND_SETTING)
    family: Family = Field(description="Family of the pressure curve. " + FAMILY_DESCRIPTION)
    efficiency_family: EfficiencyFamily = Field(
        description="Family of the efficiency curve. " + EFFICIENCY_FAMILY_DESCRIPTION)
    x_min: float = Field(description="Smallest measured flow (t = 0).", json_schema_extra=FLOW)
    x_max: float = Field(description="Largest measured flow (t = 1).", json_schema_extra=FLOW)
    pressure_coefficients: list[float] = Field(
        description="The family's coefficients; the unit of each is in pressure_coefficient_units (control "
        "values are pressures; 'log' has [a, b, c] with b a flow; 'concave' lists knot flows, then pressures).",
        json_schema_extra=unit("{settings.pressure_coefficient_units}"))
    pressure_coefficient_units: list[str | None] = Field(
        default_factory=list, description="Unit of each pressure coefficient (null: the request stated none).")
    efficiency_coefficients: list[float] = Field(
        description="Control values (fractions) and, for 'parabola_log', a and beta (in t units).", json_schema_extra=ONE)
    n_points: int
    pressure_fit: Literal["least_squares", "minimax"] = Field(
        default="least_squares", description="Criterion of this setting's pressure fit: options.fit, except "
        "where 'auto' found no least-squares fit within 1 % of the floor and took a minimax one (a "
        "'pressure_fit_minimax' warning says so), and 'least_squares' where a minimax fit's linear programme failed "
        "and least squares ran instead (a 'pressure_fit_not_minimax' warning says so).")
    pressure_max_rel_error: float = Field(description="max_i |y(x_i) - y_i| / |y_i|.", json_schema_extra=ONE)
    efficiency_max_rel_error: float = Field(description="max_i |eta(x_i) - eta_i| / |eta_i|.", json_schema_extra=ONE)
    pressure_loo: float | None = Field(
        default=None, json_schema_extra=ONE, description="Leave-one-out: max relative error of each point predicted "
        "by a least-squares fit to the other points (None when too few points; on settings "
        "with more than 20 points, 20 evenly spread points are left out).")
    efficiency_loo: float | None = Field(default=None, description="Leave-one-out max relative efficiency error.",
                                         json_schema_extra=ONE)
    efficiency_max_abs_error: float = Field(
        default=0.0, description="max_i |eta(x_i) - eta_i| (efficiency points).", json_schema_extra=ONE)
    efficiency_loo_abs: float | None = Field(
        default=None, json_schema_extra=ONE, description="Leave-one-out max absolute efficiency error ('auto' "
        "criterion for the efficiency family).")
    efficiency_peak: float = Field(
        default=0.0, json_schema_extra=ONE, description="Maximum of the fitted efficiency curve over [x_min, x_max] "
        "(exact); compare with the measured maximum of the setting.")
    efficiency_bounds_active: int = Field(
        default=0, description="Number of points where the physical bound 0 <= eta <= 1 had "
        "to be imposed on the fitted curve (0: the unconstrained fit was already physical).")
    floor: float = Field(
        json_schema_extra=ONE, description="Best max relative error of the pressure that ANY decreasing concave "
        "function can reach on these points (0 when the data are decreasing and concave).")
    pressure_excess: float = Field(
        default=0.0, json_schema_extra=ONE, description="pressure_max_rel_error - floor: what the fitted family loses against the "
        "best decreasing concave curve (a 'pressure_fit_poor' warning above 0.01).")
    active_side_conditions: int = Field(
        default=0, description="Number of side conditions (y' <= 0 at the surge end, y'' <= 0 "
        "per piece) active in the fit: the data push against the physics there.")


class ErrorTableRow(BaseModel):
    """One column of the paper's Table 1, for the submitted data (max over settings)."""

    family: Family
    n_coefficients: int
    pressure_max_rel_error: float = Field(json_schema_extra=ONE, description="Max over settings (relative).")
    efficiency_max_rel_error: float | None = Field(
        description="None for 'log' (the paper has no log efficiency curve).", json_schema_extra=ONE)
    pressure_loo: float | None = Field(json_schema_extra=ONE, description="Leave-one-out, max over settings.")
    efficiency_loo: float | None = Field(json_schema_extra=ONE, description="Leave-one-out, max over settings.")
    efficiency_max_abs_error: float | None = Field(
        default=None, description="Max over settings of max_i |eta(x_i) - eta_i|.", json_schema_extra=ONE)
    floor: float = Field(description="Max over settings of the per-setting floor.", json_schema_extra=ONE)
    worst_setting: int = Field(description="Index in `settings` of the worst pressure fit.")


class EfficiencyErrorRow(BaseModel):
    """Errors of one efficiency family over all settings (bounded fits, 0 <= eta <= 1)."""

    family: EfficiencyFamily
    n_coefficients: int
    max_rel_error: float = Field(json_schema_extra=ONE, description="Max over settings, relative.")
    max_abs_error: float = Field(json_schema_extra=ONE, description="Max over settings, absolute (fraction).")
    loo_rel: float | None = Field(description="Max over settings of the leave-one-out max "
                                  "relative error (None when some setting has too few points).", json_schema_extra=ONE)
    loo_abs: float | None = Field(json_schema_extra=ONE, description="Leave-one-out max absolute error.")
    max_overshoot: float = Field(
        description="Max over settings of (fitted peak - measured max efficiency).", json_schema_extra=ONE)
    chosen: int = Field(description="Number of settings that use this family.")


class Envelope(BaseModel):
    """Max-curve of one theta over the interpolated phi settings (paper section 3); in general, of one value
    of the other setting parameters over the last one."""

    fixed: list[float] = Field(default_factory=list, description="Values of the settings held fixed (all but the "
                               "last setting name; empty with one setting parameter).", json_schema_extra=SETTINGS)
    theta: float | None = Field(default=None, json_schema_extra=FIRST_SETTING)
    flow: list[float] = Field(json_schema_extra=FLOW)
    pressure: list[float | None] = Field(
        description="max over phi of the interpolated characteristics (null: no curve).", json_schema_extra=PRESSURE)
    phi: list[float | None] = Field(description="The last setting parameter (phi) attaining the max (paper eq. 48), "
                                    "in the last setting's unit.", json_schema_extra=SETTINGS)
    efficiency: list[float | None] = Field(
        description="eta along the max-curve (paper eq. 50).", json_schema_extra=ONE)


class LimitPoint(BaseModel):
    """One end of a characteristic (surge or choke), or its surge-margin point."""

    setting: list[float] = Field(default_factory=list, json_schema_extra=SETTINGS)
    theta: float | None = Field(default=None, json_schema_extra=FIRST_SETTING)
    phi: float | None = Field(default=None, json_schema_extra=SECOND_SETTING)
    flow: float = Field(json_schema_extra=FLOW)
    pressure: float = Field(json_schema_extra=PRESSURE)
    efficiency: float = Field(json_schema_extra=ONE)
    vertical_to: float | None = Field(
        default=None, json_schema_extra=PRESSURE, description="Choke: the lowest pressure measured at this same flow (a vertical choke "
        "segment from `pressure` down to it), null when there is none.")


class PerformanceMap(BaseModel):
    """Max efficiency over all settings whose characteristic passes through (flow, pressure).

    Grid nodes are cell centres of the bounding box of all characteristics (paper eqs. 66-67).
    Rows = pressure, columns = flow; ``null`` where no setting reaches the node.
    """

    method: Literal["exact", "binning"]
    flow: list[float] = Field(json_schema_extra=FLOW)
    pressure: list[float] = Field(json_schema_extra=PRESSURE)
    efficiency: list[list[float | None]] = Field(json_schema_extra=ONE)
    settings: list[list[list[float | None]]] = Field(
        default_factory=list, json_schema_extra=SETTINGS, description="Optimal value of each setting parameter (in the order of setting_names) "
        "per node.")
    theta: list[list[float | None]] | None = Field(default=None, description="Two setting parameters: the first.",
                                                   json_schema_extra=FIRST_SETTING)
    phi: list[list[float | None]] | None = Field(default=None, description="Two setting parameters: the second.",
                                                 json_schema_extra=SECOND_SETTING)
    t_samples: int
    reachable_fraction: float = Field(description="Fraction of grid nodes that are reachable.", json_schema_extra=ONE)


class BetaLine(BaseModel):
    """One speed line tabulated at the grid's beta values (same order as ``BetaMap.beta``)."""

    setting: list[float] = Field(description="Setting values of the line (speed last), in the order of "
                                 "setting_names.", json_schema_extra=SETTINGS)
    flow: list[float] = Field(description="Corrected flow at each beta (the result's flow unit).", json_schema_extra=FLOW)
    pressure: list[float] = Field(description="Pressure (ratio) at each beta (the result's pressure unit).",
                                  json_schema_extra=PRESSURE)
    efficiency: list[float] = Field(description="Efficiency (fraction) at each beta.", json_schema_extra=ONE)
    t: list[float] = Field(description="Curve parameter t of each node on the fitted characteristic.",
                           json_schema_extra=ONE)
    c_choke: float = Field(description="Beta-line constant c through the choke end (beta = 0).",
                           json_schema_extra=unit("{beta_map.c_unit}"))
    c_surge: float = Field(description="Beta-line constant c through the surge end (beta = 1).",
                           json_schema_extra=unit("{beta_map.c_unit}"))
    table_pressure_max_rel_error: float | None = Field(
        default=None, description="Largest relative pressure difference, at the same flow, between the fitted line and the "
        "table read linearly between its beta nodes (the chords): at a measured point the table departs from the "
        "data by at most this plus the setting's pressure_max_rel_error.", json_schema_extra=ONE)
    table_efficiency_max_abs_error: float | None = Field(
        default=None, description="The same for the efficiency, absolute (fraction). (Both are null in results "
        "stored before they were stated.)", json_schema_extra=ONE)


class BetaMap(BaseModel):
    """The fitted map tabulated on auxiliary coordinates (speed, beta) for cycle codes. """ + BETA_CONVENTION

    shape: Literal["parabola", "straight"]
    exponent: int = Field(description="p of y - y_v = c (x - x_v)^p: 2 (parabola) or 1 (straight).")
    vertex_flow: float = Field(description="x_v: 0 when every flow is positive, else below the smallest flow.",
                               json_schema_extra=FLOW)
    vertex_pressure: float = Field(description="y_v: 1 for a pressure ratio above 1 everywhere, else 0.",
                                   json_schema_extra=PRESSURE)
    c_unit: str | None = Field(default=None, description="Unit of the lines' c_choke and c_surge: pressure / flow^p "
                               "(null when the request stated neither unit).")
    spacing: Literal["adaptive", "even"] = Field(default="even", description="How the beta values were placed "
                                                 "(options.beta_grid.spacing).")
    beta: list[float] = Field(description="Beta values, 0 (choke) to 1 (surge), ascending.", json_schema_extra=ONE)
    lines: list[BetaLine] = Field(description="One per speed line, in the order of `settings`.")
    table_pressure_max_rel_error: float | None = Field(
        default=None, json_schema_extra=ONE, description="Max over lines of table_pressure_max_rel_error: how far "
        "the exported tables, read linearly between nodes, depart from the fitted map.")
    table_efficiency_max_abs_error: float | None = Field(
        default=None, json_schema_extra=ONE, description="Max over lines of table_efficiency_max_abs_error.")


class ResultUnits(BaseModel):
    """Which unit each quantity of the result is in."""

    flow: str | None = Field(description="Unit of every flow value (null: not stated in the request).")
    pressure: str | None = Field(description="Unit of every pressure value ('1' for a ratio; null: not stated).")
    efficiency: Literal["1"] = Field(default="1", description="Efficiencies are fractions (0.85, not 85 %).")
    settings: list[str | None] = Field(default_factory=list, description="Unit of each setting parameter, in the "
                                       "order of setting_names (null: not stated).")


class PerfmapResult(BaseModel):
    kind: Literal["perfmap"] = Field(default="perfmap", description="The solver kind of this result (what tells the "
                                   "results of GET /v1/jobs/{id}/result apart).")
    report: Report
    units: ResultUnits | None = Field(default=None, description="Units of flow, pressure, efficiency and settings "
                                      "in this result (and its query answers).")
    setting_names: list[str] = Field(default_factory=lambda: ["theta", "phi"])
    setting_units: list[str] | None = None
    family: Family = Field(description="Pressure family shared by the settings (a setting it cannot fit "
                           "within 1 % of its floor has its own: see settings[].family).")
    fit: Literal["least_squares", "minimax"]
    settings: list[SettingFit] = Field(description="Sorted by setting values.")
    error_table: list[ErrorTableRow] = Field(
        description="The paper's Table 1 for the submitted data, one row per family.")
    efficiency_error_table: list[EfficiencyErrorRow] = Field(
        default_factory=list,
        description="Per efficiency family: errors over all settings (the efficiency family "
        "is chosen separately from the pressure family).")
    envelopes: list[Envelope]
    surge_line: list[LimitPoint] = Field(
        default_factory=list, description="Surge (stall) end of every characteristic: its smallest measured flow, "
        "in the order of `settings`.")
    choke_line: list[LimitPoint] = Field(
        default_factory=list, description="Choke end of every characteristic: its largest measured flow.")
    surge_margin_line: list[LimitPoint] | None = Field(
        default=None, description="With options.surge_margin > 0: the point of each characteristic at that margin "
        "(null where the characteristic does not drop that far).")
    triangles: list[list[int]] = Field(
        default_factory=list,
        description="Triangulation of the settings (indices into `settings`), Delaunay on "
        "range-normalised (theta, phi); settings on one line (one setting parameter) are chained as "
        "segments written (i, j, j).")
    map: PerformanceMap | None = None
    beta_map: BetaMap | None = Field(default=None, description="The speed lines tabulated on the beta grid "
                                     "(options.beta_grid); the cycle-code exports are written from it.")
    flow_range: list[float] = Field(description="[min, max] flow over all characteristics.", json_schema_extra=FLOW)
    pressure_range: list[float] = Field(description="[min, max] pressure over all characteristics.",
                                        json_schema_extra=PRESSURE)


class QueryPoint(StrictModel):
    flow: FiniteFloat = Field(ge=-1e12, le=1e12, description="Flow of the duty point (the map's unit).")
    pressure: FiniteFloat = Field(ge=-1e12, le=1e12, description="Pressure of the duty point (the map's unit).")


class PerfmapQueryRequest(StrictModel):
    """Duty points to look up in a finished map: ``{"points": [{flow, pressure}, ...]}`` or a
    single ``{"flow": ..., "pressure": ...}``."""

    points: list[QueryPoint] = Field(min_length=1, max_length=10_000)

    @model_validator(mode="before")
    @classmethod
    def _single_point(cls, data: Any) -> Any:
        if isinstance(data, dict) and "points" not in data and {"flow", "pressure"} & set(data):
            # validated as the point it is, so that an error names its field ('units', 'flow'), not 'points.0.…'
            # (which the body does not have: the problem named '/0') or 'points' missing beside 'flow' extra
            QueryPoint.model_validate(data)
            return {"points": [data]}
        return data


class QueryAnswer(BaseModel):
    flow: float = Field(json_schema_extra=FLOW)
    pressure: float = Field(json_schema_extra=PRESSURE)
    feasible: bool = Field(description="True when some setting in the map reaches the point.")
    setting: list[float] | None = Field(default=None, description="Optimal setting values (None when infeasible).",
                                        json_schema_extra=SETTINGS)
    theta: float | None = Field(default=None, description="Two setting parameters: the first (None when infeasible).",
                                json_schema_extra=FIRST_SETTING)
    phi: float | None = Field(default=None, description="Two setting parameters: the second (None when infeasible).",
                              json_schema_extra=SECOND_SETTING)
    efficiency: float | None = Field(
        description="Max efficiency at the point (None when infeasible).", json_schema_extra=ONE)
    distance_to_map: float = Field(
        description="Distance to the reachable region in range-normalised units "
        "(flow/flow span, pressure/pressure span); 0 when feasible.", json_schema_extra=ONE)


class PerfmapQueryResult(BaseModel):
    points: list[QueryAnswer]
    units: ResultUnits | None = Field(default=None, description="Units of flow, pressure and settings (the map's; "
                                      "duty points are read in them too).")


class BetaPointBySetting(StrictModel):
    """A map lookup as a cycle code does it: setting values (speed last) and beta."""

    model_config = ConfigDict(extra="forbid", strict=True)  # strict: "0.9" is no number

    setting: list[FiniteFloat] = Field(
        min_length=1, max_length=3,
        description="Setting values in the order of the result's setting_names (speed last). The leading "
        "ones (e.g. alpha) must be values of the map; the last is interpolated between speed lines.")
    beta: FiniteFloat = Field(ge=0.0, le=1.0, description="Beta: 0 at choke, 1 at surge.")

    @property
    def speed(self) -> None:
        return None


class BetaPointBySpeed(StrictModel):
    """A lookup on a one-setting map: the speed and beta."""

    model_config = ConfigDict(extra="forbid", strict=True)

    speed: FiniteFloat = Field(description="The speed (maps whose only setting is the speed).")
    beta: FiniteFloat = Field(ge=0.0, le=1.0, description="Beta: 0 at choke, 1 at surge.")

    @property
    def setting(self) -> None:
        return None


def _beta_form(value: Any) -> str | None:
    """Which form a point (or a whole request) is in, so that only that form's rules judge it: one error per
    bad field, not one per form it might have been. A point naming ``speed`` is the speed form; any other
    object the setting form (which then names what is missing or extra)."""
    if isinstance(value, dict):
        return "points_list" if "points" in value else "by_speed" if "speed" in value else "by_setting"
    return {BetaPoints: "points_list", BetaPointBySpeed: "by_speed", BetaPointBySetting: "by_setting"}.get(type(value))


_POINT_FORMS = 'a point is an object: {"speed": number, "beta": number} or {"setting": [numbers], "beta": number}'

# one or the other, never both: two closed objects, so the contract itself says so
BetaPoint = Annotated[
    Annotated[BetaPointBySetting, Tag("by_setting")] | Annotated[BetaPointBySpeed, Tag("by_speed")],
    Discriminator(_beta_form, custom_error_type="beta_point_type", custom_error_message=_POINT_FORMS),
]


class BetaPoints(StrictModel):
    """Several lookups: ``{"points": [...]}``."""

    model_config = ConfigDict(extra="forbid", strict=True)

    points: list[BetaPoint] = Field(min_length=1, max_length=10_000)


class PerfmapBetaQueryRequest(RootModel):
    """``{"points": [{"speed": 0.9, "beta": 0.5}, ...]}``, or one point alone: ``{"speed": 0.9, "beta": 0.5}``
    (or ``{"setting": [...], "beta": ...}``). Numbers are JSON numbers (strict)."""

    root: Annotated[
        Annotated[BetaPoints, Tag("points_list")] | Annotated[BetaPointBySetting, Tag("by_setting")]
        | Annotated[BetaPointBySpeed, Tag("by_speed")],
        Discriminator(_beta_form, custom_error_type="beta_query_type",
                      custom_error_message='the body is an object: {"points": [...]} or one point; ' + _POINT_FORMS),
    ]

    @property
    def points(self) -> list[BetaPointBySetting | BetaPointBySpeed]:
        return list(self.root.points) if isinstance(self.root, BetaPoints) else [self.root]

    def place(self, i: int) -> tuple[str | int, ...]:
        """Where point ``i`` is in the body: ``("points", i)``, or the body itself for the one-point form."""
        return ("points", i) if isinstance(self.root, BetaPoints) else ()


class BetaAnswer(BaseModel):
    setting: list[float] = Field(description="Setting values asked for (speed last).")
    beta: float
    flow: float = Field(description="Corrected flow (the result's flow unit).")
    pressure: float = Field(description="Pressure (ratio) (the result's pressure unit).")
    efficiency: float = Field(description="Efficiency, a fraction.")
    on_speed_line: bool = Field(description="True when the speed is a fitted speed line (exact on the fitted "
                                "curve); otherwise linear in speed between the two neighbouring lines at the "
                                "same beta, as cycle codes interpolate their tables.")


class PerfmapBetaQueryResult(BaseModel):
    points: list[BetaAnswer]
    units: ResultUnits | None = None
