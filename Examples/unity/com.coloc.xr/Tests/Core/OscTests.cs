// The C# OSC codec: round trips, the strict layout checks, and both directions against coloc's
// own liblo-based codec (the fusion node of libcoloc_fusion_c on loopback).
using System;
using System.Collections.Generic;
using System.Net;
using System.Net.Sockets;
using System.Text;
using NUnit.Framework;

namespace Coloc.Tests
{
    [TestFixture]
    public class OscTests
    {
        static readonly Pose Sample = new Pose(new Vec3(1.5, -2.25, 1.75), Quat.AxisAngle(new Vec3(0, 0, 1), 0.5));

        static OscDrop Decode(byte[] d, out List<OscPose> poses, out List<int> requests)
        {
            poses = new List<OscPose>();
            requests = new List<int>();
            return OscCodec.Decode(d, d.Length, poses, requests, out _);
        }

        static byte[] Bundle(params byte[][] elements)
        {
            var b = new List<byte>(Encoding.ASCII.GetBytes("#bundle\0"));
            b.AddRange(new byte[] { 0, 0, 0, 0, 0, 0, 0, 1 });
            foreach (byte[] e in elements)
            {
                byte[] n = BitConverter.GetBytes(e.Length);
                if (BitConverter.IsLittleEndian) Array.Reverse(n);
                b.AddRange(n);
                b.AddRange(e);
            }
            return b.ToArray();
        }

        [Test]
        public void PoseMessageRoundTrip()
        {
            byte[] d = OscCodec.EncodePose(new OscPose(OscCodec.PoseAddress, 1000.0111111, 42, 2, Sample));
            Assert.AreEqual(68, d.Length, "the size coloc documents");
            Assert.AreEqual(OscDrop.None, Decode(d, out var poses, out _));
            Assert.AreEqual(1, poses.Count);
            OscPose p = poses[0];
            Assert.AreEqual(OscCodec.PoseAddress, p.Address);
            Assert.AreEqual(1000.0111111, p.Time); // a double on the wire
            Assert.AreEqual(42, p.Sequence);
            Assert.AreEqual(2, p.State);
            Assert.That((p.Pose.Position - Sample.Position).Norm, Is.LessThan(1e-6)); // float32
            Assert.That(Quat.AngleBetween(p.Pose.Rotation, Sample.Rotation), Is.LessThan(1e-3));
        }

        [Test]
        public void GetPoseAndBundles()
        {
            Assert.AreEqual(OscDrop.None, Decode(OscCodec.EncodeGetPose(), out _, out var r));
            Assert.AreEqual(new[] { 0 }, r.ToArray());
            Assert.AreEqual(OscDrop.None, Decode(OscCodec.EncodeGetPose(9123), out _, out r));
            Assert.AreEqual(new[] { 9123 }, r.ToArray());
            byte[] pose = OscCodec.EncodePose(new OscPose(OscCodec.FusedPoseAddress, 1, 1, 1, Sample));
            Assert.AreEqual(OscDrop.None, Decode(Bundle(pose, Bundle(pose)), out var poses, out _));
            Assert.AreEqual(2, poses.Count);
            // Five levels of bundles: one too many.
            Assert.AreEqual(OscDrop.Malformed, Decode(Bundle(Bundle(Bundle(Bundle(Bundle(pose))))), out _, out _));
        }

        [Test]
        public void StrictLayoutChecks()
        {
            byte[] good = OscCodec.EncodePose(new OscPose(OscCodec.PoseAddress, 1, 1, 1, Sample));
            var cases = new List<(string, byte[], OscDrop)>
            {
                ("truncated by 4", Slice(good, good.Length - 4), OscDrop.Malformed),
                ("size not a multiple of 4", Slice(good, good.Length - 1), OscDrop.Malformed),
                ("extra bytes", Concat(good, new byte[4]), OscDrop.Malformed),
                ("no leading /", Patch(good, 0, (byte)'x'), OscDrop.Malformed),
                ("non-zero padding", Patch(OscCodec.EncodeGetPose(), 18, (byte)'x'), OscDrop.Malformed),
                ("no type tags", Encoding.ASCII.GetBytes("/coloc/pose\0"), OscDrop.Malformed),
                ("blob past the end", Encoding.ASCII.GetBytes("/x\0\0,b\0\0").Concat4(0, 0, 1, 0), OscDrop.Malformed),
                ("blob tag and nothing", Encoding.ASCII.GetBytes("/x\0\0,b\0\0"), OscDrop.Malformed),
                ("unknown tag", Encoding.ASCII.GetBytes("/x\0\0,q\0\0"), OscDrop.Malformed),
                ("foreign address", Encoding.ASCII.GetBytes("/other\0\0,\0\0\0"), OscDrop.UnknownAddress),
                ("wrong types", Encoding.ASCII.GetBytes("/coloc/pose\0,i\0\0").Concat4(0, 0, 0, 1), OscDrop.WrongTypes),
                ("bundle element too long", Patch(Bundle(good), 19, 200), OscDrop.Malformed),
                ("oversized", new byte[OscCodec.MaxPacketSize + 4], OscDrop.Oversized),
                ("NaN position", Float(good, 40, float.NaN), OscDrop.InvalidValue),
                ("quaternion not unit", Float(good, 64, 3.0f), OscDrop.InvalidValue),
            };
            foreach (var c in cases)
            {
                Assert.AreEqual(c.Item3, Decode(c.Item2, out var poses, out _), c.Item1);
                Assert.AreEqual(0, poses.Count, c.Item1);
            }
        }

        // Both directions against libcoloc_fusion_c's liblo codec: our /coloc/xr_pose and
        // /coloc/pose into its node, its /coloc/fused_pose out to our client, its get_pose reply.
        [Test]
        public void InteroperatesWithColocsFusionNode()
        {
            TestEnvironment.RequireLibraries();
            using (var client = new OscPoseClient())
            using (var fusion = new DriftFusion(new FusionOptions { PublishUrl = "osc.udp://127.0.0.1:" + client.Port }))
            using (var sender = new UdpClient())
            {
                fusion.StartOsc();
                var node = new IPEndPoint(IPAddress.Loopback, fusion.OscPort);
                Pose xr = Pose.Identity, world = new Pose(new Vec3(2.5, 0, 1.7), Quat.Identity);
                for (int i = 0; i < 20; ++i)
                {
                    double t = 100 + i / 90.0;
                    if (i % 3 == 0) Send(sender, node, new OscPose(OscCodec.PoseAddress, t, i / 3, 1, world));
                    Send(sender, node, new OscPose(OscCodec.XrPoseAddress, t, i, 1, xr));
                }
                byte[] garbage = Encoding.ASCII.GetBytes("/x\0\0,b\0\0");
                sender.Send(garbage, garbage.Length, node);
                Assert.IsTrue(Eventually(() => fusion.Stats.XrPoses == 20 && fusion.Stats.OscMalformed == 1), "the node got 20 headset poses and 1 malformed packet");
                var received = new List<OscPose>();
                Assert.IsTrue(Eventually(() => { while (client.TryTake(out OscPose p)) received.Add(p); return received.Count == 20; }),
                    "20 /coloc/fused_pose from the node, got " + received.Count);
                Assert.AreEqual(OscCodec.FusedPoseAddress, received[19].Address);
                Assert.AreEqual((int)FusionState.Tracking, received[19].State);
                Assert.That((received[19].Pose.Position - world.Position).Norm, Is.LessThan(1e-3));
                OscPose reply = OscPoseClient.RequestPose("127.0.0.1", fusion.OscPort, TimeSpan.FromSeconds(30));
                Assert.AreEqual(OscCodec.FusedPoseAddress, reply.Address);
                Assert.That((reply.Pose.Position - world.Position).Norm, Is.LessThan(1e-3));
                Assert.AreEqual(0, client.Stats.Dropped);
                fusion.StopOsc();
            }
        }

        static void Send(UdpClient s, IPEndPoint to, OscPose p)
        {
            byte[] d = OscCodec.EncodePose(p);
            s.Send(d, d.Length, to);
        }

        // Polls a condition for up to 60 s: a generous deadline, not a timing assumption.
        internal static bool Eventually(Func<bool> condition, double seconds = 60)
        {
            DateTime deadline = DateTime.UtcNow.AddSeconds(seconds);
            while (!condition())
            {
                if (DateTime.UtcNow > deadline) return false;
                System.Threading.Thread.Sleep(5);
            }
            return true;
        }

        static byte[] Slice(byte[] d, int n) { var o = new byte[n]; Array.Copy(d, o, n); return o; }
        static byte[] Concat(byte[] a, byte[] b) { var o = new byte[a.Length + b.Length]; a.CopyTo(o, 0); b.CopyTo(o, a.Length); return o; }
        static byte[] Patch(byte[] d, int at, byte v) { var o = (byte[])d.Clone(); o[at] = v; return o; }
        static byte[] Float(byte[] d, int at, float v)
        {
            var o = (byte[])d.Clone();
            byte[] f = BitConverter.GetBytes(v);
            if (BitConverter.IsLittleEndian) Array.Reverse(f);
            Array.Copy(f, 0, o, at, 4);
            return o;
        }
    }

    static class ByteExtensions
    {
        public static byte[] Concat4(this byte[] d, byte a, byte b, byte c, byte e)
        {
            var o = new byte[d.Length + 4];
            d.CopyTo(o, 0);
            o[d.Length] = a; o[d.Length + 1] = b; o[d.Length + 2] = c; o[d.Length + 3] = e;
            return o;
        }
    }
}
