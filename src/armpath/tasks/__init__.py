"""The seed scene's jobs (SPEC section 4), composed from the layers below."""

from armpath.tasks.seed_tasks import SEED_TASKS, reach_task, spotweld_task, trace_task

__all__ = ["SEED_TASKS", "reach_task", "spotweld_task", "trace_task"]
