"""Unsupervised datasets: ExORL-layout storage, loading and sampling, collection, coverage."""

from fbil.data.dataset import Dataset, TransitionBatch, load_dataset
from fbil.data.storage import list_episodes, load_episode, write_episode

__all__ = [
    "Dataset",
    "TransitionBatch",
    "list_episodes",
    "load_dataset",
    "load_episode",
    "write_episode",
]
