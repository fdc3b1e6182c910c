"""The progress bar of the training loops (pre-training and Stage I/II), shared so they look alike."""

from __future__ import annotations

__all__ = ["StageBar"]


class StageBar:
    """One rich progress bar on stderr per stage of a long job (preprocessing, training); a no-op when disabled."""

    def __init__(self, enabled: bool) -> None:
        self.progress = None
        if enabled:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self.progress = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                                     TextColumn("{task.fields[info]}"), TimeElapsedColumn(),
                                     console=Console(stderr=True))
            self.progress.start()
        self.task = None

    def stage(self, description: str, total: int, done: int = 0) -> None:
        if self.progress is not None:
            if self.task is not None:
                self.progress.stop_task(self.task)
            self.task = self.progress.add_task(description, total=total, completed=done, info="")

    def update(self, done: int, info: str = "") -> None:
        if self.progress is not None and self.task is not None:
            self.progress.update(self.task, completed=done, info=info)

    def close(self) -> None:
        if self.progress is not None:
            self.progress.stop()
