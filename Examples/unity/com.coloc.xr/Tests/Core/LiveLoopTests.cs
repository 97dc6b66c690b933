// The live loop on loopback: `coloc localize` on the twin room streams /coloc/pose to the C#
// client; each received pose goes into the fusion through P/Invoke together with the twin's
// drifting 90 Hz headset stream; the fused head, in Unity's frame, is compared with the truth
// converted to Unity's frame. Paced by events, not by the clock: a headset pose is fused once
// the localizer has streamed past its time (or finished), whatever the machine's speed.
using System;
using System.Collections.Generic;
using System.Globalization;
using System.IO;
using System.Linq;
using System.Text.RegularExpressions;
using NUnit.Framework;

namespace Coloc.Tests
{
    [TestFixture]
    public class LiveLoopTests
    {
        [Test]
        public void LocalizerToClientToFusionInUnitysFrame()
        {
            TestEnvironment.RequireLibraries();
            string twin = TestEnvironment.Twin;
            var xr = TestEnvironment.ReadTum(Path.Combine(twin, "headset", "headset.txt"));
            var truth = TestEnvironment.ByMicroseconds(TestEnvironment.ReadTum(Path.Combine(twin, "headset", "headset_groundtruth.txt")));
            int listen = TestEnvironment.FreeUdpPort();

            using (var client = new OscPoseClient())
            using (var fusion = new DriftFusion())
            using (var localize = TestEnvironment.Start(TestEnvironment.Coloc, string.Join(" ",
                "localize", "--map", Quote(Path.Combine(TestEnvironment.Fixture, "site.db")),
                "--sequence", Quote(Path.Combine(twin, "sequence")),
                "--cam-from-head", Quote(Path.Combine(twin, "headset", "calibration.yaml")),
                "--publish", "osc.udp://127.0.0.1:" + client.Port, "--listen", listen.ToString(),
                "--linger", "3", "--json")))
            {
                string summary = "";
                localize.OutputDataReceived += (s, e) => { if (e.Data != null) summary += e.Data; };
                localize.ErrorDataReceived += (s, e) => { };
                localize.BeginOutputReadLine();
                localize.BeginErrorReadLine();

                var global = new List<OscPose>();
                int delivered = 0, expected = -1;
                OscPose? onDemand = null;
                var errors = new List<double>();
                Pose lastFused = Pose.Identity, lastTruth = Pose.Identity;
                DateTime deadline = DateTime.UtcNow.AddSeconds(600);
                foreach (var h in xr)
                {
                    // Wait until the stream has passed this headset time, or the localizer has
                    // finished and every pose it published has been taken.
                    while (expected < 0 || global.Count < expected)
                    {
                        if (global.Count > 0 && global[global.Count - 1].Time >= h.Time) break;
                        if (client.WaitTake(out OscPose p, TimeSpan.FromMilliseconds(50)))
                        {
                            Assert.AreEqual(OscCodec.PoseAddress, p.Address);
                            global.Add(p);
                            // On demand, once, while the localizer is still busy: its latest pose.
                            if (onDemand == null)
                                onDemand = OscPoseClient.RequestPose("127.0.0.1", listen, TimeSpan.FromSeconds(60));
                            continue;
                        }
                        if (expected < 0 && localize.HasExited)
                        {
                            localize.WaitForExit(); // flushes the summary
                            expected = Published(summary);
                        }
                        Assert.That(DateTime.UtcNow, Is.LessThan(deadline),
                            $"the localizer stopped streaming: {global.Count} poses received, {expected} published");
                    }
                    for (; delivered < global.Count && global[delivered].Time <= h.Time; ++delivered)
                        fusion.PushGlobalPose(global[delivered].Time, global[delivered].Pose, (TrackingState)global[delivered].State);

                    // The headset's pose as Unity's XR rig reports it, fused, in Unity's frame.
                    FusedPose fused = fusion.PushUnityXrPose(h.Time, Frames.ScanToUnity(h.Pose));
                    if (fused.State != FusionState.Tracking) continue;
                    Pose truthUnity = Frames.ScanToUnity(truth[(long)Math.Round(h.Time * 1e6)]);
                    errors.Add((fused.WorldFromHead.Position - truthUnity.Position).Norm);
                    lastFused = fused.WorldFromHead;
                    lastTruth = truthUnity;
                }
                Assert.IsTrue(localize.WaitForExit(600 * 1000), "coloc localize did not finish");
                localize.WaitForExit();
                Assert.AreEqual(0, localize.ExitCode, "coloc localize failed: " + summary);
                int localized = Field(summary, "localized");

                OscClientStats stats = client.Stats;
                FusionStats fs = fusion.Stats;
                Assert.That(errors.Count, Is.GreaterThan(xr.Count / 2), "fused poses while tracking");
                var sorted = errors.OrderBy(e => e).ToList();
                double median = sorted[sorted.Count / 2], max = sorted[sorted.Count - 1];
                double rmse = Math.Sqrt(errors.Sum(e => e * e) / errors.Count);
                double last = (lastFused.Position - lastTruth.Position).Norm;
                TestEnvironment.Report($"live loop: coloc localize localized {localized} frames; the C# client received {global.Count} /coloc/pose, " +
                    $"dropped {stats.Dropped}; fusion accepted {fs.Accepted} of {fs.GlobalPoses}, rejected {fs.Rejected}");
                TestEnvironment.Report($"live loop: fused head vs truth in Unity's frame over {errors.Count} headset poses: " +
                    $"median {median * 100:F2} cm, RMSE {rmse * 100:F2} cm, max {max * 100:F2} cm, last {last * 100:F2} cm");
                Assert.IsNotNull(onDemand, "/coloc/get_pose answered");
                TestEnvironment.Report($"live loop: /coloc/get_pose answered with the pose of t = {onDemand.Value.Time:F3} s (state {onDemand.Value.State})");
                Assert.AreEqual(OscCodec.PoseAddress, onDemand.Value.Address);

                // Loopback loses nothing the localizer sent, and every packet was well formed.
                Assert.AreEqual(localized, global.Count, "one /coloc/pose per localized frame");
                Assert.AreEqual(0, stats.Dropped);
                // The fused head sits within 1 cm of the truth in Unity's frame.
                Assert.That(median, Is.LessThan(0.01), "median fused head error");
                Assert.That(last, Is.LessThan(0.01), "fused head error at the end of the walk");
            }
        }

        static string Quote(string s) => "\"" + s + "\"";

        // An integer of `coloc localize --json`'s one-line summary.
        static int Field(string json, string name)
        {
            Match m = Regex.Match(json, "\"" + name + "\":(\\d+)");
            Assert.IsTrue(m.Success, $"no {name} in the summary: {json}");
            return int.Parse(m.Groups[1].Value, CultureInfo.InvariantCulture);
        }

        static int Published(string json) => Field(json, "published");
    }
}
