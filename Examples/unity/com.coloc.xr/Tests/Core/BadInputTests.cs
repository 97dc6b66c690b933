// Bad input never crashes the host process: a missing library, an ABI mismatch, bad options and
// poses, a closed port, a port in use and malformed packets each give a clear exception or a
// counted drop.
using System;
using System.Collections.Generic;
using System.IO;
using System.Net;
using System.Net.Sockets;
using System.Text;
using NUnit.Framework;

namespace Coloc.Tests
{
    [TestFixture]
    public class BadInputTests
    {
        // In a child process without LD_LIBRARY_PATH: the load fails there, cleanly, with the
        // package's message (a process can load a library only once, so not in this one).
        [Test]
        public void MissingLibraryIsAClearException()
        {
            string probe = TestEnvironment.Require("COLOC_UNITY_PROBE");
            var env = new Dictionary<string, string> { ["LD_LIBRARY_PATH"] = "/nonexistent", ["MONO_PATH"] = Path.GetDirectoryName(probe) };
            var run = TestEnvironment.Run("mono", $"\"{probe}\"", 120, env);
            Console.WriteLine(run.Stdout + run.Stderr);
            Assert.AreEqual(3, run.ExitCode, "the probe caught ColocLibraryException: " + run.Stdout + run.Stderr);
            StringAssert.Contains("libcoloc_fusion_c could not be loaded", run.Stdout);
            StringAssert.Contains("LD_LIBRARY_PATH", run.Stdout);
        }

        [Test]
        public void AbiMismatchIsAClearException()
        {
            TestEnvironment.RequireLibraries();
            var e = Assert.Throws<ColocAbiException>(() => ColocLibrary.CheckFusion(ColocLibrary.FusionAbiVersion + 1));
            StringAssert.Contains($"ABI version {ColocLibrary.FusionAbiVersion}, this package", e.Message);
            Assert.Throws<ColocAbiException>(() => ColocLibrary.CheckLocalize(ColocLibrary.LocalizeAbiVersion + 1));
            ColocLibrary.CheckFusion(ColocLibrary.FusionAbiVersion); // and the right one passes
            ColocLibrary.CheckLocalize(ColocLibrary.LocalizeAbiVersion);
            // The library's own check of the options' ABI field, its message carried over.
            var c = Assert.Throws<ColocException>(() => new DriftFusion(new FusionOptions(), 999));
            StringAssert.Contains("abi_version mismatch", c.Message);
        }

        [Test]
        public void BadOptionsAndPosesCarryTheLibrarysMessage()
        {
            TestEnvironment.RequireLibraries();
            var e = Assert.Throws<ColocException>(() => new DriftFusion(new FusionOptions { MeasurementNoise = -1 }));
            StringAssert.Contains("measurement_noise", e.Message);
            e = Assert.Throws<ColocException>(() => new DriftFusion(new FusionOptions { PublishUrl = "http://nowhere" }));
            StringAssert.Contains("url", e.Message);
            using (var fusion = new DriftFusion())
            {
                var nan = new Pose(new Vec3(double.NaN, 0, 0), Quat.Identity);
                e = Assert.Throws<ColocException>(() => fusion.PushXrPose(1.0, nan));
                StringAssert.Contains("COLOC_ERROR_INVALID_ARGUMENT", e.Message);
                StringAssert.Contains("headset pose is NULL or not finite", e.Message);
                Assert.AreEqual(1, e.Status);
                e = Assert.Throws<ColocException>(() => fusion.PushGlobalPose(1.0, Pose.Identity, (TrackingState)7));
                StringAssert.Contains("tracking must be 0, 1, 2 or 3", e.Message);
                fusion.PushXrPose(2.0, Pose.Identity); // still usable
                // A pose the localizer bridged by odometry is taken and ignored, not an error.
                fusion.PushGlobalPose(2.0, Pose.Identity, TrackingState.Odometry);
            }
            var disposed = new DriftFusion();
            disposed.Dispose();
            Assert.Throws<ObjectDisposedException>(() => disposed.PushXrPose(1.0, Pose.Identity));
        }

        [Test]
        public void MissingMapIsAClearException()
        {
            TestEnvironment.RequireLibraries();
            var e = Assert.Throws<ColocException>(() => new Localizer("/nonexistent/site.db", "/nonexistent/vocabulary.cvoc"));
            StringAssert.Contains("/nonexistent/", e.Message);
        }

        [Test]
        public void ClosedPortIsAClearException()
        {
            int port = TestEnvironment.FreeUdpPort(); // nothing listens there now
            var e = Assert.Throws<ColocOscException>(() => OscPoseClient.RequestPose("127.0.0.1", port, TimeSpan.FromSeconds(20)));
            Console.WriteLine(e.Message);
            StringAssert.Contains("127.0.0.1:" + port, e.Message);
        }

        [Test]
        public void PortInUseIsAClearException()
        {
            using (var first = new OscPoseClient())
            {
                var e = Assert.Throws<ColocOscException>(() => new OscPoseClient(new OscClientOptions { Port = first.Port }));
                StringAssert.Contains("cannot listen on 127.0.0.1:" + first.Port, e.Message);
            }
        }

        [Test]
        public void MalformedPacketsAreCountedDrops()
        {
            using (var client = new OscPoseClient())
            using (var sender = new UdpClient())
            {
                var to = new IPEndPoint(IPAddress.Loopback, client.Port);
                var bad = new List<byte[]>
                {
                    Encoding.ASCII.GetBytes("/x\0\0,b\0\0"),            // blob tag, no blob
                    Encoding.ASCII.GetBytes("not osc at all!!"),        // no '/'
                    Encoding.ASCII.GetBytes("/coloc/pose\0,i\0\0\0\0\0\u0001"), // wrong types
                    Encoding.ASCII.GetBytes("/elsewhere\0\0,\0\0\0"),   // foreign address
                    new byte[2000],                                      // oversized
                };
                foreach (byte[] b in bad) sender.Send(b, b.Length, to);
                byte[] good = OscCodec.EncodePose(new OscPose(OscCodec.PoseAddress, 5, 1, 1, Pose.Identity));
                sender.Send(good, good.Length, to);
                Assert.IsTrue(client.WaitTake(out OscPose p, TimeSpan.FromSeconds(60)), "the good pose after the bad ones");
                Assert.AreEqual(5.0, p.Time);
                Assert.IsTrue(OscTests.Eventually(() => client.Stats.Packets == 6));
                OscClientStats s = client.Stats;
                Assert.AreEqual(2, s.Malformed);
                Assert.AreEqual(1, s.WrongTypes);
                Assert.AreEqual(1, s.UnknownAddress);
                Assert.AreEqual(1, s.Oversized);
                Assert.AreEqual(5, s.Dropped);
                Assert.AreEqual(1, s.Poses);
                TestEnvironment.Report($"bad packets to the C# client: {s.Dropped} counted drops of {s.Packets} packets, last: {client.LastDropReason}");
            }
        }
    }
}
