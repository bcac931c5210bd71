"""The studies by the KIND that names them on the command line."""
from studies.compare import study_compare
from studies.convergence import study_convergence
from studies.coupling import study_coupling
from studies.envelope import study_envelope
from studies.modes import study_modes
from studies.stability import study_stability
from studies.timing import study_timing
from studies.work_precision import study_work_precision


STUDIES = {
    "convergence": study_convergence,
    "work-precision": study_work_precision,
    "coupling": study_coupling,
    "stability": study_stability,
    "modes": study_modes,
    "compare": study_compare,
    "timing": study_timing,
    "envelope": study_envelope,
}
