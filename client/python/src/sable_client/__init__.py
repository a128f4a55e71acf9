"""Python client of Sable, the simulation service for granular and soft-particle materials.

Submit a scene, watch it run, and read its samples as pandas DataFrames::

    from sable_client import Client

    with Client("http://127.0.0.1:8080") as sable:
        job = sable.submit("biaxial_test_2d")       # scenes/biaxial_test_2d.json
        sable.watch(job)                            # progress bar with live Φ, Z, p, μ
        df = sable.samples(job)                     # one row per sample
        df.plot(x="strain.deviatoric", y="zeta")    # ζ = q/p against strain

Every call is a route of the service's OpenAPI document (``GET /v1/openapi.json``); the
package's version is the service's.
"""

from .client import LIVE_FIELDS, Client, JobRef, StudyRef
from .errors import Conflict, JobFailed, NotFound, RejectedScene, SableError, ServiceBusy, Unauthorized, Violation
from .frames import flatten, samples_frame, study_frame
from .models import TERMINAL_STATES, Job, Snapshot, State, Study
from .routes import ROUTES, Route
from .scenes import SceneLike, load_scene
from .sse import Event
from .vtk import PolyData, read_polydata

__version__ = "0.1.0"

__all__ = [
    "Client",
    "Conflict",
    "Event",
    "Job",
    "JobFailed",
    "JobRef",
    "LIVE_FIELDS",
    "NotFound",
    "PolyData",
    "ROUTES",
    "RejectedScene",
    "Route",
    "SableError",
    "SceneLike",
    "ServiceBusy",
    "Snapshot",
    "State",
    "Study",
    "StudyRef",
    "TERMINAL_STATES",
    "Unauthorized",
    "Violation",
    "flatten",
    "load_scene",
    "read_polydata",
    "samples_frame",
    "study_frame",
    "__version__",
]
