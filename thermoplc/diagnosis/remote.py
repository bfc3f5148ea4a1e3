"""A diagnosis round's candidates as tasks of a Dask cluster (`diagnose --scheduler`): each candidate effect is
refitted and judged on a worker, which reads the runs where it runs (recordings/campaign.CampaignSource), rebuilds
the parts as `diagnose` does, and recomputes the current model's residual and score from the model itself, so
what it judges is the same bits as in one process. Only the candidate's fitted model comes back; the client
simulates it again (cheap beside the refit) for the residuals the search keeps."""
from __future__ import annotations

from dataclasses import dataclass

from thermoplc.base.cluster import Cluster, Lost
from thermoplc.base.errors import ClusterError
from thermoplc.diagnosis.parts import Parts
from thermoplc.diagnosis.runs import DiagnoseRequest, parts_of
from thermoplc.diagnosis.search import Attempt, attempt, completed
from thermoplc.recordings.campaign import CampaignSource
from thermoplc.physics.fitted import Simulation


@dataclass(frozen=True)
class CandidateTask:
    source: CampaignSource
    request: DiagnoseRequest
    current: Simulation
    sigma: dict
    target: str
    name: str
    sensor: int | None


_LAST_PARTS: list = []


def _parts(task: CandidateTask) -> Parts:
    """The diagnosis's runs rebuilt from the files, the last kept (a worker tries many candidates of one run)."""
    key = (task.source.key, task.request)
    if not _LAST_PARTS or _LAST_PARTS[0] != key:
        _LAST_PARTS[:] = [key, parts_of(task.source.read(), task.request)[0]]
    return _LAST_PARTS[1]


def try_on_worker(task: CandidateTask) -> Attempt:
    """One candidate refitted and judged; its fitted model without the residuals (the client rebuilds them)."""
    return attempt(_parts(task), task.target, task.current, task.sigma, task.name, task.sensor)


@dataclass(frozen=True)
class OnCluster:
    """`search.diagnose_runs`'s `tries`: every candidate of a round on `cluster`, the attempts in their order."""
    cluster: Cluster
    source: CampaignSource
    request: object

    def __call__(self, parts: Parts, target: str, current: Simulation, sigma: dict, options: list, say) -> list:
        tasks = [CandidateTask(self.source, self.request, current, sigma, target, name, sensor)
                 for name, sensor in options]
        found: list = [None] * len(tasks)
        names = [f"candidate {name}" + (f" on {parts.runs[0].names[sensor]}" if sensor is not None else "")
                 for name, sensor in options]
        for done, (k, result) in enumerate(self.cluster.run(try_on_worker, tasks, "candidate", names), start=1):
            if isinstance(result, Lost):
                raise ClusterError(f"diagnose: {names[k]}: {result}")
            found[k] = result
            say(f"tested {done}/{len(tasks)} candidates on the cluster")
        return [completed(a, parts, target, sigma) for a in found]
