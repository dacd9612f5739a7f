"""Random frame trees for the tf tests, and their transforms composed by hand (4x4 matrices)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pytransform3d.rotations import quaternion_slerp
from pytransform3d.transformations import transform_from_pq

from zros.tf import Buffer


@dataclass
class Edge:
    parent: str
    child: str
    stamps: np.ndarray  # int64 ns (one for a static edge)
    poses: np.ndarray  # (n, 7): x y z qx qy qz qw
    static: bool

    def matrix_at(self, stamp: int) -> np.ndarray:
        """T_parent_child at ``stamp``, interpolated independently of zros (numpy's interp for
        the translation, pytransform3d's slerp for the rotation)."""
        if self.static:
            return matrix(self.poses[0])
        i = int(np.searchsorted(self.stamps, stamp, side='right')) - 1
        if i == len(self.stamps) - 1 or self.stamps[i] == stamp:
            return matrix(self.poses[i])
        ratio = (stamp - self.stamps[i]) / (self.stamps[i + 1] - self.stamps[i])
        p0, p1 = self.poses[i], self.poses[i + 1]
        translation = p0[:3] + ratio * (p1[:3] - p0[:3])
        q0 = np.r_[p0[6], p0[3:6]]  # pytransform3d orders w x y z
        q1 = np.r_[p1[6], p1[3:6]]
        q = quaternion_slerp(q0, q1, ratio, shortest_path=True)
        return transform_from_pq(np.r_[translation, q])


@dataclass
class Tree:
    edges: dict[str, Edge] = field(default_factory=dict)  # by child

    def path_to_root(self, frame: str) -> list[str]:
        path = [frame]
        while path[-1] in self.edges:
            path.append(self.edges[path[-1]].parent)
        return path

    def matrix(self, target: str, source: str, stamp: int) -> np.ndarray:
        """T_target_source by hand: each frame's matrix in the root, composed."""
        return np.linalg.inv(self.in_root(target, stamp)) @ self.in_root(source, stamp)

    def in_root(self, frame: str, stamp: int) -> np.ndarray:
        out = np.eye(4)
        for child in self.path_to_root(frame)[:-1]:
            out = self.edges[child].matrix_at(stamp) @ out
        return out

    def depth(self, frame: str) -> int:
        return len(self.path_to_root(frame)) - 1

    def buffer(self, cache_time: float | None = None) -> Buffer:
        buffer = Buffer(cache_time=cache_time)
        for edge in self.edges.values():
            for stamp, pose in zip(edge.stamps, edge.poses, strict=True):
                assert buffer.add(
                    edge.parent, edge.child, int(stamp), tuple(pose), 'test', static=edge.static
                )
        return buffer


def matrix(pose: np.ndarray) -> np.ndarray:
    """A 4x4 matrix of a (x y z qx qy qz qw) pose."""
    return transform_from_pq(np.r_[pose[:3], pose[6], pose[3:6]])


def random_pose(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return np.r_[rng.uniform(-3, 3, size=3), q]


def random_tree(
    rng: np.random.Generator,
    depth: int,
    *,
    extra: int = 4,
    grid: np.ndarray | None = None,
    samples: int = 6,
) -> Tree:
    """A tree whose deepest frame is ``depth`` edges below the root: a spine of ``depth``
    edges, then ``extra`` frames hung anywhere above that depth. About a third of the edges are
    static; moving ones have ``samples`` random stamps, or the stamps of ``grid``."""
    tree = Tree()
    frames = ['f0']
    for i in range(1, depth + 1):
        _add(tree, rng, f'f{i - 1}', f'f{i}', grid=grid, samples=samples)
        frames.append(f'f{i}')
    for j in range(extra):
        parents = [f for f in frames if tree.depth(f) < depth]
        parent = parents[int(rng.integers(len(parents)))]
        _add(tree, rng, parent, f'x{j}', grid=grid, samples=samples)
        frames.append(f'x{j}')
    return tree


def _add(
    tree: Tree,
    rng: np.random.Generator,
    parent: str,
    child: str,
    *,
    grid: np.ndarray | None,
    samples: int,
) -> None:
    static = rng.random() < 0.33
    if static:
        stamps = np.array([0], dtype=np.int64)
    elif grid is not None:
        stamps = grid
    else:
        stamps = np.sort(
            rng.choice(np.arange(1_000_000_000, 2_000_000_000, 1000), samples, replace=False)
        ).astype(np.int64)
    poses = np.array([random_pose(rng) for _ in stamps])
    tree.edges[child] = Edge(parent, child, stamps, poses, static)
