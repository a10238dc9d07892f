# Hand-written stubs of the compiled extension `robot_stiffness._core` (Rust, pyo3).
# Private API: the documented entry points are robot_stiffness.so3 / .csjm / .vjm.
# Arrays are float64; the pure-Python wrappers convert other dtypes first.
import os
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt

_F64 = npt.NDArray[np.float64]
_Model = Union[str, Sequence[str]]
_Path = Union[str, os.PathLike[str]]
# A diagnosis as the core hands it over: the result without its rows as plain values (dicts,
# lists, numbers, strings, None; robot_stiffness.results builds the typed classes from it) and
# the rows as numpy columns.
_CoreValue = Union[None, bool, int, float, str, List["_CoreValue"], Dict[str, "_CoreValue"]]
_CoreDiagnosis = Tuple[Dict[str, _CoreValue], Dict[str, npt.NDArray[np.generic]]]

__all__ = [
    "CsjmCampaign",
    "CsjmEstimate",
    "DesignPlan",
    "IdentificationPartial",
    "MeasurementColumns",
    "PaperClippedAngle",
    "PaperErrors",
    "PaperFigures",
    "PaperModelErrors",
    "PaperStudy",
    "PaperStudyRows",
    "PlannedCombination",
    "PredictionColumns",
    "VJM_COMPENSATION_COLUMNS",
    "VJM_PREDICTION_COLUMNS",
    "VJM_SAG_COLUMNS",
    "Robot",
    "StiffnessModel",
    "VjmCampaign",
    "__version__",
    "_panic_for_tests",
    "csjm_diagnose",
    "csjm_diagnose_csv",
    "csjm_identify",
    "csjm_identify_csv",
    "csjm_read_csv",
    "csjm_simulate",
    "so3_adjoint",
    "so3_distance",
    "so3_exp",
    "so3_hat",
    "so3_left_jacobian",
    "so3_left_jacobian_inverse",
    "so3_log",
    "so3_orthogonality_error",
    "so3_project_to_rotation",
    "so3_right_jacobian",
    "so3_right_jacobian_inverse",
    "so3_vee",
    "vjm_compensate",
    "vjm_compensate_model_file",
    "vjm_design",
    "vjm_diagnose",
    "vjm_deflection_under_gravity",
    "vjm_gravity_sag",
    "vjm_gravity_stiffness",
    "vjm_gravity_torques",
    "vjm_identify_model",
    "vjm_identify_timed",
    "vjm_jacobian_timed",
    "vjm_model_file_robot",
    "vjm_read_csv",
    "vjm_read_poses",
    "vjm_paper_study",
    "vjm_simulate",
    "vjm_to_csv",
    "vjm_write_compensation",
    "vjm_write_predictions",
]

__version__: str
# The columns of PRED.csv after q1..qn, its sag columns, and of COMP.csv after the targets.
VJM_PREDICTION_COLUMNS: List[str]
VJM_SAG_COLUMNS: List[str]
VJM_COMPENSATION_COLUMNS: List[str]

def _panic_for_tests() -> None: ...
def so3_hat(w: _F64) -> _F64: ...
def so3_vee(m: _F64) -> _F64: ...
def so3_exp(w: _F64) -> _F64: ...
def so3_log(r: _F64, tol: float) -> _F64: ...
def so3_adjoint(r: _F64, tol: float) -> _F64: ...
def so3_left_jacobian(w: _F64) -> _F64: ...
def so3_right_jacobian(w: _F64) -> _F64: ...
def so3_left_jacobian_inverse(w: _F64) -> _F64: ...
def so3_right_jacobian_inverse(w: _F64) -> _F64: ...
def so3_distance(a: _F64, b: _F64, tol: float) -> _F64: ...
def so3_project_to_rotation(m: _F64) -> _F64: ...
def so3_orthogonality_error(m: _F64) -> _F64: ...
def csjm_identify(
    r: _F64,
    tau: _F64,
    reference: int,
    order: int = 1,
    project: bool = False,
    tol: Optional[float] = None,
    convergence: bool = True,
) -> CsjmEstimate: ...
def csjm_simulate(
    effects_list: List[Dict[str, _CoreValue]],
    seed: int = 0,
    increments: Optional[int] = None,
    max_increment: Optional[float] = None,
) -> CsjmCampaign: ...
def csjm_diagnose(
    r: _F64,
    tau: _F64,
    reference: int,
    fdr: Optional[float] = None,
    test_fraction: Optional[float] = None,
    split_seed: Optional[int] = None,
    project: bool = False,
    progress: Optional[Callable[[str, int, int], Any]] = None,
) -> _CoreDiagnosis: ...
def csjm_diagnose_csv(
    path: _Path,
    fdr: Optional[float] = None,
    test_fraction: Optional[float] = None,
    split_seed: Optional[int] = None,
    project: bool = False,
    progress: Optional[Callable[[str, int, int], Any]] = None,
) -> _CoreDiagnosis: ...
def csjm_read_csv(path: _Path, project: bool = False) -> Tuple[_F64, _F64, int]: ...
def csjm_identify_csv(path: _Path, order: int = 1, project: bool = False) -> CsjmEstimate: ...
def vjm_read_csv(path: _Path, n_joints: int, sha256: bool = True) -> MeasurementColumns: ...
def vjm_to_csv(
    n_joints: int,
    q: _F64,
    wrench: _F64,
    displacement: _F64,
    rotation: Optional[_F64] = None,
    pose: Optional[npt.NDArray[np.int64]] = None,
    set: Optional[Sequence[str]] = None,
) -> str: ...
def vjm_simulate(
    robot: Robot,
    effects: List[Dict[str, _CoreValue]],
    n_poses: int = 40,
    wrenches_per_pose: int = 4,
    seed: int = 0,
    noise: bool = True,
    torsion: Optional[_F64] = None,
    force_max: Optional[float] = None,
    moment_max: Optional[float] = None,
    test_fraction: Optional[float] = None,
    gravity: Optional[Tuple[float, float, float]] = None,
    plan: Optional[Tuple[_F64, _F64, npt.NDArray[np.int64]]] = None,
) -> VjmCampaign: ...
def vjm_identify_timed(
    robot: Robot,
    q: _F64,
    wrench: _F64,
    displacement: _F64,
    model: _Model,
    repeats: int = 1,
) -> List[float]: ...
def vjm_jacobian_timed(robot: Robot, q: _F64, model: _Model, repeats: int = 1) -> List[float]: ...
def vjm_gravity_torques(
    robot: Robot,
    q: _F64,
    model: _Model,
    gravity: Tuple[float, float, float],
    payload: Optional[Tuple[float, Tuple[float, float, float]]] = None,
) -> _F64: ...
def vjm_gravity_sag(
    robot: Robot,
    compliance: _F64,
    q: _F64,
    model: _Model,
    gravity: Tuple[float, float, float],
    payload: Optional[Tuple[float, Tuple[float, float, float]]] = None,
) -> _F64: ...
def vjm_deflection_under_gravity(
    robot: Robot,
    compliance: _F64,
    q: _F64,
    wrench: _F64,
    model: _Model,
    gravity: Tuple[float, float, float],
    payload: Optional[Tuple[float, Tuple[float, float, float]]] = None,
) -> _F64: ...
def vjm_gravity_stiffness(
    robot: Robot,
    q: _F64,
    model: _Model,
    gravity: Tuple[float, float, float],
    payload: Optional[Tuple[float, Tuple[float, float, float]]] = None,
) -> _F64: ...
def vjm_identify_model(
    robot: Robot,
    q: _F64,
    wrench: _F64,
    displacement: _F64,
    model: _Model,
    rotation: Optional[_F64] = None,
    noise_sigma: Optional[_F64] = None,
    noise_scale_known: bool = False,
    nonnegative: bool = False,
    dense: bool = False,
    method: str = "auto",
    data_file: Optional[str] = None,
    robust_covariance: bool = False,
    allow_outside_limits: bool = False,
    gravity: Optional[Tuple[float, float, float]] = None,
    data_sha256: Optional[str] = None,
) -> Tuple[Dict[str, _CoreValue], StiffnessModel]: ...
def vjm_read_poses(path: _Path, robot: Robot) -> Tuple[_F64, Optional[_F64], Optional[npt.NDArray[np.int64]]]: ...
def vjm_write_predictions(
    path: _Path,
    q: _F64,
    wrench: _F64,
    deflection: _F64,
    stddev: _F64,
    identified: npt.NDArray[np.bool_],
    sag: Optional[Tuple[_F64, _F64, npt.NDArray[np.bool_]]] = None,
) -> None: ...
def vjm_write_compensation(
    path: _Path,
    q: _F64,
    q_nominal: _F64,
    values: _F64,
    iterations: npt.NDArray[np.int64],
    limit_joint: npt.NDArray[np.int64],
    status: List[str],
) -> None: ...
def vjm_model_file_robot(
    path: _Path,
) -> Optional[Tuple[Optional[str], str, str, Optional[str], List[str]]]: ...
def vjm_compensate(
    robot: Robot,
    model: _Model,
    compliance: _F64,
    q: _F64,
    wrench: Optional[_F64] = None,
    payload: Optional[Tuple[float, Sequence[float]]] = None,
    match_orientation: bool = False,
    with_kc: bool = True,
    allow_outside_limits: bool = False,
    gravity: Optional[Tuple[float, float, float]] = None,
) -> Tuple[_F64, _F64, List[str]]: ...
def vjm_compensate_model_file(
    robot: Robot,
    path: str,
    q: _F64,
    wrench: Optional[_F64] = None,
    payload: Optional[Tuple[float, Sequence[float]]] = None,
    match_orientation: Optional[bool] = None,
    with_kc: bool = True,
    allow_outside_limits: bool = False,
    gravity: Optional[Tuple[float, float, float]] = None,
    recorded_gravity: bool = False,
) -> Tuple[_F64, _F64, List[str]]: ...
def vjm_design(
    robot: Robot,
    model: _Model,
    poses: int = 24,
    wrenches_per_pose: int = 4,
    seed: int = 0,
    margin: float = 0.1,
    pool_size: int = 300,
    force: float = 80.0,
    moment: float = 3.0,
    progress: Optional[Callable[[str, int, int], Any]] = None,
    gravity: Optional[Tuple[float, float, float]] = None,
) -> DesignPlan: ...
def vjm_paper_study(
    robot: Robot,
    tilt_ratio: Optional[float] = None,
    noise: bool = True,
    seed: int = 0,
    links: bool = False,
    link_share: Optional[float] = None,
) -> PaperStudy: ...
def vjm_diagnose(
    robot: Robot,
    q: _F64,
    wrench: _F64,
    displacement: _F64,
    rotation: Optional[_F64] = None,
    pose: Optional[npt.NDArray[np.int64]] = None,
    set: Optional[Sequence[str]] = None,
    baseline: Optional[_Model] = None,
    fdr: Optional[float] = None,
    test_fraction: Optional[float] = None,
    split_seed: Optional[int] = None,
    max_findings: Optional[int] = None,
    progress: Optional[Callable[[str, int, int], Any]] = None,
    allow_outside_limits: bool = False,
    tracker_sigma: Optional[float] = None,
    force_sigma: Optional[float] = None,
    moment_sigma: Optional[float] = None,
    per_row: bool = True,
    gravity: Optional[Tuple[float, float, float]] = None,
) -> _CoreDiagnosis: ...

@final
class PaperErrors:
    """One error metric of one model over the seed's 26 tests (fractions)."""

    @property
    def identification(self) -> float: ...
    @property
    def verification(self) -> float: ...
    @property
    def all(self) -> float: ...
    @property
    def verification_max(self) -> float: ...
    @property
    def verification_max_test(self) -> int: ...

@final
class PaperModelErrors:
    """Both error metrics of one model."""

    @property
    def magnitude(self) -> PaperErrors: ...
    @property
    def vector(self) -> PaperErrors: ...

@final
class PaperStudyRows:
    """The 26 tests as columns: ids and flags (26,), vectors (26, 3) m, errors (26,)."""

    @property
    def test(self) -> npt.NDArray[np.int64]: ...
    @property
    def configuration(self) -> npt.NDArray[np.int64]: ...
    @property
    def load(self) -> npt.NDArray[np.int64]: ...
    @property
    def identification(self) -> npt.NDArray[np.bool_]: ...
    @property
    def measured(self) -> _F64: ...
    @property
    def traditional(self) -> _F64: ...
    @property
    def extended(self) -> _F64: ...
    @property
    def full(self) -> _F64: ...
    @property
    def traditional_magnitude_error(self) -> _F64: ...
    @property
    def traditional_vector_error(self) -> _F64: ...
    @property
    def extended_magnitude_error(self) -> _F64: ...
    @property
    def extended_vector_error(self) -> _F64: ...
    @property
    def full_magnitude_error(self) -> _F64: ...
    @property
    def full_vector_error(self) -> _F64: ...

@final
class PaperClippedAngle:
    """A Table I angle moved inside the joint limits (1-based configuration and joint, rad)."""

    @property
    def configuration(self) -> int: ...
    @property
    def joint(self) -> int: ...
    @property
    def table(self) -> float: ...
    @property
    def used(self) -> float: ...

@final
class PaperFigures:
    """The seed's own figures (fractions, magnitude metric)."""

    @property
    def traditional_all(self) -> float: ...
    @property
    def extended_all(self) -> float: ...
    @property
    def extended_verification_max(self) -> float: ...
    @property
    def extended_verification_max_test(self) -> int: ...
    @property
    def traditional_verification_max(self) -> float: ...
    @property
    def torsion_share(self) -> float: ...

@final
class PaperStudy:
    """The seed study: the three models' errors, the 26 tests, ranks, the truth's shares."""

    @property
    def traditional(self) -> PaperModelErrors: ...
    @property
    def extended(self) -> PaperModelErrors: ...
    @property
    def full(self) -> PaperModelErrors: ...
    @property
    def rows(self) -> PaperStudyRows: ...
    @property
    def extended_rank(self) -> int: ...
    @property
    def full_rank(self) -> int: ...
    @property
    def torsion_share(self) -> float: ...
    @property
    def link_share(self) -> float: ...
    @property
    def tilt_ratio(self) -> float: ...
    @property
    def link_scale(self) -> float: ...
    @property
    def clipped(self) -> List[PaperClippedAngle]: ...
    @property
    def paper(self) -> PaperFigures: ...

@final
class PlannedCombination:
    """A combination a plan determines: label, predicted stderr (None when not finite), terms
    as (parameter index, coefficient), weak."""

    @property
    def label(self) -> str: ...
    @property
    def stderr(self) -> Optional[float]: ...
    @property
    def terms(self) -> List[Tuple[int, float]]: ...
    @property
    def weak(self) -> bool: ...

@final
class DesignPlan:
    """A planned VJM campaign: rows (rad, N, N·m, base frame) and what the plan determines."""

    @property
    def q(self) -> _F64: ...
    @property
    def wrench(self) -> _F64: ...
    @property
    def pose(self) -> npt.NDArray[np.int64]: ...
    @property
    def rank(self) -> int: ...
    @property
    def combinations(self) -> List[PlannedCombination]: ...
    @property
    def worst_stderr(self) -> Optional[float]: ...
    @property
    def noise(self) -> Dict[str, _CoreValue]: ...
    @property
    def pose_compliance_wrenches(self) -> int: ...

@final
class CsjmCampaign:
    """A simulated CSJM campaign: the measurement file's text and the hidden truth at R₀."""

    @property
    def csv(self) -> str: ...
    @property
    def true_K(self) -> _F64: ...
    @property
    def true_K_D(self) -> _F64: ...
    @property
    def true_R0(self) -> _F64: ...

@final
class VjmCampaign:
    """A simulated VJM campaign: the measurements and the hidden truth (m, N, N·m)."""

    @property
    def measurements(self) -> MeasurementColumns: ...
    @property
    def csv(self) -> str: ...
    @property
    def true_displacement(self) -> _F64: ...
    @property
    def applied_wrench(self) -> _F64: ...
    @property
    def tip(self) -> _F64: ...
    @property
    def truth(self) -> Dict[str, _CoreValue]: ...
    @property
    def spec(self) -> Dict[str, _CoreValue]: ...

@final
class CsjmEstimate:
    """A CSJM stiffness estimate, frame A at R₀ (N·m/rad, N·m)."""

    @property
    def K(self) -> _F64: ...
    @property
    def K_D(self) -> _F64: ...
    @property
    def K_L(self) -> _F64: ...
    @property
    def K_stderr(self) -> _F64: ...
    @property
    def tau0(self) -> _F64: ...
    @property
    def offset(self) -> _F64: ...
    @property
    def n(self) -> int: ...
    @property
    def order(self) -> int: ...
    @property
    def dof(self) -> int: ...
    @property
    def residual_rms(self) -> _F64: ...
    @property
    def omega_singular_values(self) -> _F64: ...
    @property
    def omega_condition(self) -> float: ...
    @property
    def regressor_condition(self) -> float: ...
    @property
    def asymmetry(self) -> float: ...
    @property
    def det_convergence_n(self) -> _F64: ...
    @property
    def det_convergence_det(self) -> _F64: ...
    @property
    def curvature(self) -> Optional[_F64]: ...

@final
class PredictionColumns:
    """Predicted tip deflections of N rows, base frame (m, rad, N, N·m)."""

    @property
    def deflection(self) -> _F64: ...
    @property
    def stddev(self) -> _F64: ...
    @property
    def wrench(self) -> _F64: ...
    @property
    def identified(self) -> npt.NDArray[np.bool_]: ...
    @property
    def excitation(self) -> _F64: ...

@final
class MeasurementColumns:
    """A VJM measurement table as read (rad, N, N·m, m) and the SHA-256 of its bytes."""

    @property
    def q(self) -> _F64: ...
    @property
    def wrench(self) -> _F64: ...
    @property
    def displacement(self) -> _F64: ...
    @property
    def rotation(self) -> Optional[_F64]: ...
    @property
    def pose(self) -> Optional[npt.NDArray[np.int64]]: ...
    @property
    def set(self) -> Optional[List[str]]: ...
    @property
    def sha256(self) -> Optional[str]: ...

@final
class Robot:
    @staticmethod
    def bundled(tip: Optional[str] = None) -> Robot: ...
    @staticmethod
    def from_urdf(path: _Path, base: str, tip: str) -> Robot: ...
    @staticmethod
    def from_urdf_string(xml: str, base: str, tip: str) -> Robot: ...
    @property
    def n_joints(self) -> int: ...
    @property
    def joint_names(self) -> List[str]: ...
    @property
    def limits(self) -> List[Tuple[float, float]]: ...
    @property
    def base_link(self) -> str: ...
    @property
    def tip_link(self) -> str: ...
    def __reduce__(self) -> Tuple[Any, Tuple[str, str, str, Optional[str]]]: ...
    @staticmethod
    def _from_pickle(xml: str, base: str, tip: str, path: Optional[str] = None) -> Robot: ...
    def model_labels(self, model: _Model) -> List[str]: ...
    def forward_kinematics(self, q: _F64) -> _F64: ...
    def jacobian(self, q: _F64, model: _Model) -> _F64: ...
    def predict_deflection(
        self,
        compliance: _F64,
        q: _F64,
        wrench: _F64,
        model: _Model,
        with_kc: bool = False,
        allow_outside_limits: bool = False,
    ) -> _F64: ...

@final
class IdentificationPartial:
    @staticmethod
    def empty(
        robot: Robot,
        model: _Model,
        noise_sigma: Optional[_F64] = None,
        noise_scale_known: bool = False,
        nonnegative: bool = False,
        rotations: bool = False,
    ) -> IdentificationPartial: ...
    @staticmethod
    def accumulate(
        robot: Robot,
        q: _F64,
        wrench: _F64,
        displacement: _F64,
        model: _Model,
        rotation: Optional[_F64] = None,
        noise_sigma: Optional[_F64] = None,
        noise_scale_known: bool = False,
        nonnegative: bool = False,
        allow_outside_limits: bool = False,
    ) -> IdentificationPartial: ...
    def merge(self, other: IdentificationPartial) -> IdentificationPartial: ...
    def finish(self) -> Tuple[Dict[str, _CoreValue], StiffnessModel]: ...
    @property
    def n_measurements(self) -> int: ...
    @property
    def n_equations(self) -> int: ...
    @property
    def labels(self) -> List[str]: ...
    @property
    def robot(self) -> Robot: ...
    def __reduce__(self) -> Tuple[Any, Tuple[Robot, Any]]: ...
    @staticmethod
    def _from_pickle(robot: Robot, state: Any) -> IdentificationPartial: ...

@final
class StiffnessModel:
    @staticmethod
    def from_json(text: str, robot: Robot) -> StiffnessModel: ...
    @staticmethod
    def load(path: _Path, robot: Robot) -> StiffnessModel: ...
    def save(self, path: _Path) -> None: ...
    def to_json(self) -> str: ...
    def to_json_at(self, path: _Path) -> str: ...
    def to_dict(self) -> Any: ...
    @property
    def content_sha256(self) -> str: ...
    @property
    def labels(self) -> List[str]: ...
    @property
    def gravity(self) -> Optional[List[float]]: ...
    @property
    def has_rotations(self) -> bool: ...
    @property
    def rank(self) -> int: ...
    @property
    def determined_compliance(self) -> List[float]: ...
    @property
    def gear_curves(self) -> List[Tuple[int, List[float], List[float], float]]: ...
    def with_gear_curves(self, curves: List[Tuple[int, List[float], List[float], float]]) -> StiffnessModel: ...
    def measurement_stddev(self) -> List[float]: ...
    def predict(
        self,
        q: _F64,
        wrench: Optional[_F64] = None,
        payload: Optional[Tuple[float, float, float, float]] = None,
        allow_outside_limits: bool = False,
        gravity: Optional[Tuple[float, float, float]] = None,
    ) -> PredictionColumns: ...
    def predict_sag(
        self,
        q: _F64,
        gravity: Tuple[float, float, float],
        payload: Optional[Tuple[float, float, float, float]] = None,
        allow_outside_limits: bool = False,
    ) -> PredictionColumns: ...
    def compensate(
        self,
        q: _F64,
        wrench: Optional[_F64] = None,
        payload: Optional[Tuple[float, Sequence[float]]] = None,
        match_orientation: Optional[bool] = None,
        with_kc: bool = True,
        allow_outside_limits: bool = False,
        gravity: Optional[Tuple[float, float, float]] = None,
        recorded_gravity: bool = False,
    ) -> Tuple[_F64, _F64, List[str]]: ...
