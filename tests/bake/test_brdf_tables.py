"""Tabulated and measured (MERL) BRDFs: interpolation, files with known content, hostile headers."""

import struct

import numpy as np
import pytest

from bake import brdf
from bake.brdf import merl
from bake.brdf.tabulated import AnisotropicTable, IsotropicTable
from tests.bake.reference import direction, reference_albedo


def test_isotropic_table_is_exact_at_nodes_and_close_between():
    model = brdf.parse("ggx:roughness=0.6")
    table = IsotropicTable.from_model(model, (46, 46, 91))
    # At grid nodes the table returns the sampled values exactly.
    wi = direction(np.degrees(np.pi / 2 * 10 / 45), 60.0)
    wo = direction(np.degrees(np.pi / 2 * 20 / 45), 0.0)
    np.testing.assert_allclose(table.f(wi, wo), model.f(wi, wo), rtol=1e-9)
    # Between nodes: trilinear error ~ h^2 |f''| / 8 for a 2-degree grid on a
    # broad lobe; a few percent of the value.
    rng = np.random.default_rng(3)
    v = rng.normal(size=(2, 4000, 3))
    v[..., 2] = np.abs(v[..., 2]) + 0.2
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    exact, approx = model.f(v[0], v[1]), table.f(v[0], v[1])
    assert np.median(np.abs(approx - exact) / exact) < 0.01
    # Usable as any model: its albedo tracks the analytic one.
    wo = direction(30.0)
    np.testing.assert_allclose(table.albedo(wo), model.albedo(wo), rtol=0.02)
    np.testing.assert_allclose(table.albedo(wo), reference_albedo(table, wo, 200), rtol=5e-3)


def test_anisotropic_table_follows_an_anisotropic_model():
    model = brdf.parse("ggx:roughness=0.7,anisotropy=0.5,rotation=0.1")
    table = AnisotropicTable.from_model(model, (24, 64, 24, 64))
    rng = np.random.default_rng(4)
    v = rng.normal(size=(2, 3000, 3))
    v[..., 2] = np.abs(v[..., 2]) + 0.3
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    exact, approx = model.f(v[0], v[1]), table.f(v[0], v[1])
    assert np.median(np.abs(approx - exact) / exact) < 0.03
    iso = IsotropicTable.from_model(model, (24, 24, 33))
    # An isotropic table cannot hold it: its error is much larger.
    assert np.median(np.abs(iso.f(v[0], v[1]) - exact) / exact) > \
        3 * np.median(np.abs(approx - exact) / exact)


def test_table_file_spec_round_trip(tmp_path):
    model = brdf.parse("beckmann:roughness=0.5")
    table = IsotropicTable.from_model(model, (16, 16, 17))
    path = tmp_path / "t.npz"
    np.savez(path, values=table.values)
    loaded = brdf.parse(f"table:file={path}")
    wi, wo = direction(20, 10), direction(50, 200)
    np.testing.assert_array_equal(loaded.f(wi, wo), table.f(wi, wo))
    np.savez(tmp_path / "bad.npz", other=np.zeros(3))
    with pytest.raises(brdf.SpecError, match="no 'values'"):
        brdf.parse(f"table:file={tmp_path / 'bad.npz'}")


def _known_merl(dims=(90, 90, 180)):
    """Values that encode their own bin indices, so every lookup is checkable."""
    ih, idd, ip = np.meshgrid(*(np.arange(d) for d in dims), indexing="ij")
    return np.stack([ih, idd, ip], -1) * 1e-3 + 1e-6


def test_merl_reader_round_trips_and_looks_up_the_right_bin(tmp_path):
    values = _known_merl()
    path = merl.write(tmp_path / "known.binary", values)
    assert path.stat().st_size == 12 + 3 * 90 * 90 * 180 * 8
    np.testing.assert_allclose(merl.read(path), values, rtol=1e-12)
    model = brdf.parse(f"merl:file={path}")
    # Directions built from chosen (theta_h, theta_d, phi_d) bin centres.
    rng = np.random.default_rng(5)
    ih, idd, ip = rng.integers(5, 85, 200), rng.integers(0, 60, 200), rng.integers(0, 180, 200)
    theta_h = ((ih + 0.5) / 90) ** 2 * np.pi / 2
    theta_d = (idd + 0.5) / 90 * np.pi / 2
    phi_d = (ip + 0.5) / 180 * np.pi
    d = np.stack([np.sin(theta_d) * np.cos(phi_d), np.sin(theta_d) * np.sin(phi_d),
                  np.cos(theta_d)], -1)
    def rot_y(v, a):
        return np.stack([np.cos(a) * v[..., 0] + np.sin(a) * v[..., 2], v[..., 1],
                         -np.sin(a) * v[..., 0] + np.cos(a) * v[..., 2]], -1)
    mirror_d = d * np.array([-1, -1, 1])
    wi, wo = rot_y(d, theta_h), rot_y(mirror_d, theta_h)
    above = (wi[:, 2] > 0.05) & (wo[:, 2] > 0.05)
    got = model.f(wi[above], wo[above])
    np.testing.assert_allclose(got, values[ih, idd, ip][above], rtol=1e-9)
    # Reciprocity holds for MERL lookups (phi_d folds by pi).
    np.testing.assert_allclose(model.f(wo[above], wi[above]), got, rtol=1e-9)


def test_merl_file_of_an_analytic_model_reproduces_it(tmp_path):
    model = brdf.parse("ggx:roughness=0.5")
    nh, nd, npd = 90, 90, 180
    th = ((np.arange(nh) + 0.5) / nh) ** 2 * np.pi / 2
    td = (np.arange(nd) + 0.5) / nd * np.pi / 2
    pd = (np.arange(npd) + 0.5) / npd * np.pi
    TH, TD, PD = np.meshgrid(th, td, pd, indexing="ij")
    d = np.stack([np.sin(TD) * np.cos(PD), np.sin(TD) * np.sin(PD), np.cos(TD)], -1)
    c, s = np.cos(TH)[..., None], np.sin(TH)[..., None]
    def rot(v):
        return np.concatenate([c * v[..., :1] + s * v[..., 2:], v[..., 1:2],
                               -s * v[..., :1] + c * v[..., 2:]], -1)
    values = model.f(rot(d), rot(d * np.array([-1, -1, 1])))
    measured = brdf.parse(f"merl:file={merl.write(tmp_path / 'ggx.binary', values)}")
    wo = direction(30.0)
    np.testing.assert_allclose(measured.albedo(wo), model.albedo(wo), rtol=0.03)


@pytest.mark.parametrize(("header", "extra", "message"), [
    ((90, 90, 180), 100, "bytes, expected"),
    ((2**30, 2**30, 2**30), 0, "implausible dimensions"),
    ((-1, 90, 180), 0, "implausible dimensions"),
    ((1024, 1024, 1024), 0, "too many"),
])
def test_hostile_merl_headers_are_refused_before_allocating(tmp_path, header, extra, message):
    path = tmp_path / "hostile.binary"
    path.write_bytes(struct.pack("<3i", *header) + b"\0" * extra)
    with pytest.raises(brdf.SpecError, match=message):
        merl.read(path)
    (tmp_path / "short.binary").write_bytes(b"\x01\x02")
    with pytest.raises(brdf.SpecError, match="too short"):
        merl.read(tmp_path / "short.binary")
