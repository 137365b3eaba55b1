"""The client against a real cleave-server (conftest.py starts it)."""
from __future__ import annotations


import grpc
import numpy as np
import pytest

import cleave_client as cc
from conftest import SCENES, Proxy, Server, embedded_run, read_vtp


def test_submit_watch_fetch_gives_the_embedded_runs_arrays(client, tmp_path):
    scene = SCENES / "two_disks.toml"
    job = client.submit(scene, label="python test")
    assert job.submitted.state in ("queued", "running") and job.submitted.label == "python test"
    events = list(job.watch())
    # every event once, in order, ending with the final state
    assert [e.sequence for e in events] == list(range(len(events)))
    states = [e.state for e in events if isinstance(e, cc.StateChanged)]
    assert states == ["queued", "running", "succeeded"]
    assert any(isinstance(e, cc.Progressed) for e in events)
    done = [e for e in events if isinstance(e, cc.Finished)]
    assert len(done) == 1 and done[0].summary.steps > 0
    info = job.wait()
    assert info.state == "succeeded" and info.summary == done[0].summary

    ref = embedded_run(scene, tmp_path / "embedded")
    vtps = sorted(ref.glob("particles_*.vtp"))
    snaps = job.snapshots()
    assert len(snaps) == len(vtps) and snaps[-1].index == len(vtps) - 1
    fields = job.fields("latest")
    assert fields.snapshot.index == snaps[-1].index and fields.snapshot.dimension == 2
    want = read_vtp(vtps[-1])
    n = fields.snapshot.particles
    assert fields["position"].shape == (n, 2) and fields["stress"].shape == (n, 4)
    # bit for bit: a 2D run's VTK has z = 0 columns and 6-component tensors
    # (xx yy zz xy yz xz) where the service sends (xx, yy, xy, zz)
    np.testing.assert_array_equal(fields["position"], want["position"][:, :2])
    np.testing.assert_array_equal(fields["velocity"], want["velocity"][:, :2])
    np.testing.assert_array_equal(fields["stress"], want["stress"][:, [0, 1, 3, 2]])
    np.testing.assert_array_equal(fields["strain"], want["strain"][:, [0, 1, 3, 2]])
    for name in ("mass", "volume", "material_id", "body_id", "particle_id"):
        np.testing.assert_array_equal(fields[name], want[name])
    assert fields["particle_id"].dtype == np.uint32
    # an earlier snapshot by index, chosen fields only
    first = job.fields(0, names=["position", "mass"])
    assert list(first) == ["position", "mass"] and first.snapshot.time == 0.0
    np.testing.assert_array_equal(first["position"], read_vtp(vtps[0])["position"][:, :2])
    # the grid, with its geometry
    grid = job.fields("latest", location="grid")
    g = grid.grid
    assert grid["mass"].shape == (g.nodes,) and grid["velocity"].shape == (g.nodes, 2)
    assert g.reshape(grid["mass"]).shape == (1, g.shape[1], g.shape[0])
    assert g.coordinates()[1, 0] == pytest.approx(g.origin[0] + g.spacing)
    assert grid["mass"].sum() == pytest.approx(fields["mass"].sum(), rel=1e-9)
    # the series, against the embedded run's series.csv
    series = job.series()
    text = (ref / "series.csv").read_text().splitlines()
    assert list(series.dtype.names) == text[0].split(",")
    csv = np.array([[float(x) for x in line.split(",")] for line in text[1:]])
    got = np.column_stack([series[c] for c in series.dtype.names])
    np.testing.assert_array_equal(got, csv)


def test_a_dropped_connection_mid_watch_resumes_without_losing_or_repeating(server):
    proxy = Proxy(server.port)
    try:
        with cc.Client(proxy.url) as c:
            job = c.submit(SCENES / "two_disks.toml")
            seen = []
            for e in job.watch():
                seen.append(e)
                # cut the connection while the job runs, twice
                if len(seen) in (5, 40):
                    proxy.cut()
            # each cut broke a live stream, and the watch connected again
            assert proxy.cuts == 2 and job.reconnects >= 2
    finally:
        proxy.close()
    assert [e.sequence for e in seen] == list(range(len(seen)))
    assert isinstance(seen[-1], cc.StateChanged) and seen[-1].state == "succeeded"
    # the same events as a watch that was never cut
    with cc.Client(server.url) as c:
        assert list(c.job(job.id).watch()) == seen


def test_a_bad_scene_raises_with_the_fields_path(client):
    bad = (SCENES / "wave_bar.toml").read_text().replace("youngs_modulus = 2.0e11", "youngs_modulus = -3")
    with pytest.raises(cc.InvalidScene) as e:
        client.submit(bad)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert cc.FieldError("materials.steel.youngs_modulus", "must be > 0, got -3") in e.value.fields
    assert "materials.steel.youngs_modulus" in str(e.value)
    # ValidateScene says the same without raising
    v = client.validate(bad)
    assert not v.valid and v.errors == e.value.fields
    with pytest.raises(cc.InvalidScene):
        v.raise_for_errors()
    # a dict and JSON text are scenes too
    ok = client.validate(cc._scene.scene_document(SCENES / "two_disks.toml"))
    assert ok.valid and ok.particles == 6456 and ok.stages[0] == "p2g"
    # request fields, unknown jobs
    with pytest.raises(cc.InvalidArgument) as e:
        client.job("not a job id").info()
    assert [f.path for f in e.value.fields] == ["job_id"]
    with pytest.raises(cc.NotFound):
        client.job("job-999999").info()
    job = client.submit(SCENES / "two_disks.toml")
    job.wait()
    with pytest.raises(cc.InvalidArgument) as e:
        job.fields(0, names=["no_such_field"])
    assert [f.path for f in e.value.fields] == ["fields"]


def test_a_scene_with_thousands_of_problems_is_refused_as_invalid(client):
    # the refusal carries as many problems as fit in a few KiB of trailers
    # (over the clients' cap it would arrive as RESOURCE_EXHAUSTED), and
    # says how many more ValidateScene lists
    doc = cc._scene.scene_document(SCENES / "two_disks.toml")
    doc["bodies"] = [dict(doc["bodies"][0], material=f"nope{i}") for i in range(3000)]
    with pytest.raises(cc.InvalidScene) as e:
        client.submit(doc)
    fields = e.value.fields
    assert 1 <= len(fields) < 3000 and all(f.path.startswith("bodies[") for f in fields), fields[:3]
    assert f"and {3000 - len(fields)} more problems (ValidateScene lists every one)" in e.value.message
    assert len(client.validate(doc).errors) == 3000


def test_cancel_and_a_failed_wait(client):
    job = client.submit(SCENES / "two_disks.toml")
    job.cancel()
    with pytest.raises(cc.JobFailed) as e:
        job.wait(timeout=60)
    assert e.value.job.state == "cancelled"
    assert job.wait(raise_on_failure=False).state == "cancelled"
    assert any(j.id == job.id and j.state == "cancelled" for j in client.jobs(state="cancelled"))


def test_a_token_is_sent_and_its_absence_refused(tmp_path):
    s = Server(tmp_path / "data", "--token", "s3cret")
    try:
        with cc.Client(s.url) as c:
            with pytest.raises(cc.Unauthenticated):
                c.validate(SCENES / "two_disks.toml")
        with cc.Client(s.url, token="s3cret") as c:
            assert c.validate(SCENES / "two_disks.toml").valid
    finally:
        s.stop()


def test_a_server_that_is_not_there_is_unavailable():
    with cc.Client("127.0.0.1:1", timeout=5) as c:
        with pytest.raises(cc.Unavailable):
            c.validate(SCENES / "two_disks.toml")
        with pytest.raises(cc.Unavailable):
            list(c.job("job-000001").watch(reconnect_timeout=0.5))


def self_signed(tmp_path):
    """A certificate for localhost and 127.0.0.1, and its key (PEM files)."""
    import datetime
    import ipaddress

    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "localhost")])
    now = datetime.datetime.now(datetime.timezone.utc)
    cert = (x509.CertificateBuilder().subject_name(name).issuer_name(name)
            .public_key(key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=1))
            .add_extension(x509.SubjectAlternativeName([
                x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]), critical=False)
            .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
            .sign(key, hashes.SHA256()))
    cert_path, key_path = tmp_path / "cert.pem", tmp_path / "key.pem"
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_path.write_bytes(key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                           serialization.NoEncryption()))
    return cert_path, key_path


def test_tls_with_the_servers_authority(tmp_path):
    cert, key = self_signed(tmp_path)
    s = Server(tmp_path / "data", "--tls-cert", str(cert), "--tls-key", str(key))
    try:
        with cc.Client(f"https://localhost:{s.port}", ca_cert=cert) as c:
            job = c.submit(SCENES / "two_disks.toml")
            assert job.wait().state == "succeeded"
            assert job.fields(names=["mass"])["mass"].shape == (6456,)
        # plain text to a TLS server, or TLS without its authority, fails
        with cc.Client(f"localhost:{s.port}", timeout=5) as c:
            with pytest.raises(cc.CleaveError):
                c.validate(SCENES / "two_disks.toml")
        with cc.Client(f"https://localhost:{s.port}", timeout=5) as c:
            with pytest.raises(cc.Unavailable):
                c.validate(SCENES / "two_disks.toml")
    finally:
        s.stop()
