// Drift fusion in process through libcoloc_fusion_c: headset poses xr_from_head in, fused
// world_from_head (scan frame) out, global poses world_from_head from the localizer in between.
// Poses are in coloc's right-handed frames; the *Unity methods convert at the boundary
// (Frames), so MonoBehaviours never touch a scan-frame number.
using System;
using System.Runtime.InteropServices;
using Coloc.Native;

namespace Coloc
{
    // Numbers as on the wire and in the C ABI.
    // Odometry: the localizer is outside its map, carrying its pose on by visual odometry; the
    // fusion ignores such poses (they drift like the headset).
    public enum TrackingState { Lost = 0, Tracking = 1, Relocalized = 2, Odometry = 3 }
    public enum FusionState { Waiting = 0, Tracking = 1, Holding = 2 }

    public sealed class FusionOptions
    {
        public double ProcessNoise = 0.001;
        public double MeasurementNoise = 0.9;
        public double TranslationSigma = 0.03; // m
        public double RotationSigma = 0.01;    // quaternion units
        public bool Gating = true;
        public double GateChi2 = 16.27;
        public bool TimeAlignment = true;
        public double HoldAfter = 0.5;          // s
        public double MaxCorrectionSpeed = 0.0; // m/s, 0 = no limit
        public double MaxCorrectionRate = 0.0;  // rad/s, 0 = no limit
        public string BindAddress = "127.0.0.1";
        public int Port = 0;                    // 0 = any free port
        public string PublishUrl = null;        // osc.udp://host:port for /coloc/fused_pose

        // The library's defaults (coloc_fusion_default_options), which the fields above copy.
        public static FusionOptions FromLibrary()
        {
            ColocLibrary.EnsureFusion();
            var n = new coloc_fusion_options();
            NativeMethods.coloc_fusion_default_options(ref n);
            return new FusionOptions
            {
                ProcessNoise = n.process_noise, MeasurementNoise = n.measurement_noise,
                TranslationSigma = n.translation_sigma, RotationSigma = n.rotation_sigma,
                Gating = n.gating != 0, GateChi2 = n.gate_chi2, TimeAlignment = n.time_alignment != 0,
                HoldAfter = n.hold_after, MaxCorrectionSpeed = n.max_correction_speed,
                MaxCorrectionRate = n.max_correction_rate, Port = n.port,
            };
        }
    }

    public struct FusedPose
    {
        public readonly double Time;
        public readonly Pose WorldFromHead;
        public readonly FusionState State;
        public FusedPose(double time, Pose worldFromHead, FusionState state)
        {
            Time = time; WorldFromHead = worldFromHead; State = state;
        }
    }

    public struct FusionStats
    {
        public ulong XrPoses, GlobalPoses, Accepted, Initialized, Rejected, Lost, Unaligned, OutOfOrder;
        public ulong OscPackets, OscMessages, OscMalformed, OscOversized, OscWrongTypes,
            OscUnknownAddress, OscInvalidValues, OscOutOfOrder, OscPublished;
        public FusionState State;
    }

    public sealed class DriftFusion : IDisposable
    {
        readonly FusionHandle handle;

        public DriftFusion(FusionOptions options = null) : this(options ?? new FusionOptions(), 0) { }

        // abiOverride != 0 writes that ABI version into the options: the tests of the library's
        // own check of coloc_fusion_options.abi_version.
        internal DriftFusion(FusionOptions o, uint abiOverride)
        {
            ColocLibrary.EnsureFusion();
            var n = new coloc_fusion_options();
            NativeMethods.coloc_fusion_default_options(ref n);
            if (abiOverride != 0) n.abi_version = abiOverride;
            n.process_noise = o.ProcessNoise;
            n.measurement_noise = o.MeasurementNoise;
            n.translation_sigma = o.TranslationSigma;
            n.rotation_sigma = o.RotationSigma;
            n.gating = o.Gating ? 1 : 0;
            n.gate_chi2 = o.GateChi2;
            n.time_alignment = o.TimeAlignment ? 1 : 0;
            n.hold_after = o.HoldAfter;
            n.max_correction_speed = o.MaxCorrectionSpeed;
            n.max_correction_rate = o.MaxCorrectionRate;
            n.port = o.Port;
            // The strings are borrowed for the create call only (c_api.h): freed right after.
            IntPtr bind = IntPtr.Zero, publish = IntPtr.Zero;
            var error = new byte[512];
            try
            {
                bind = Utf8Alloc(o.BindAddress);
                publish = Utf8Alloc(o.PublishUrl);
                n.bind_address = bind;
                n.publish_url = publish;
                handle = NativeMethods.coloc_fusion_create(ref n, error, (UIntPtr)error.Length);
            }
            finally
            {
                if (bind != IntPtr.Zero) Marshal.FreeHGlobal(bind);
                if (publish != IntPtr.Zero) Marshal.FreeHGlobal(publish);
            }
            if (handle == null || handle.IsInvalid)
                throw new ColocException("coloc_fusion_create failed: " + NativeMethods.FromBuffer(error));
        }

        // Scan frame: a global pose world_from_head stamped at the camera's exposure.
        public void PushGlobalPose(double time, Pose worldFromHead, TrackingState tracking = TrackingState.Tracking)
        {
            var p = ToNative(time, worldFromHead);
            Check(NativeMethods.coloc_fusion_push_global_pose(handle, ref p, (int)tracking), "push_global_pose");
        }

        // Scan frame: a headset pose xr_from_head (right-handed); returns world_from_head.
        public FusedPose PushXrPose(double time, Pose xrFromHead)
        {
            var p = ToNative(time, xrFromHead);
            Check(NativeMethods.coloc_fusion_push_xr_pose(handle, ref p, out coloc_pose fused, out int state), "push_xr_pose");
            return FromNative(fused, state);
        }

        // Unity frame in and out: the XR rig's head pose in its tracking space, and the fused head
        // in the scan's frame converted to Unity's axes.
        public FusedPose PushUnityXrPose(double time, Pose unityXrFromHead)
        {
            FusedPose f = PushXrPose(time, Frames.UnityToScan(unityXrFromHead));
            return new FusedPose(f.Time, Frames.ScanToUnity(f.WorldFromHead), f.State);
        }

        public FusedPose Latest
        {
            get
            {
                Check(NativeMethods.coloc_fusion_get_fused_pose(handle, out coloc_pose fused, out int state), "get_fused_pose");
                return FromNative(fused, state);
            }
        }

        // The library's own OSC receiver (/coloc/pose, /coloc/xr_pose, /coloc/get_pose) on
        // OscPort; an alternative to feeding it from OscPoseClient.
        public void StartOsc() => Check(NativeMethods.coloc_fusion_start_osc(handle), "start_osc");
        public void StopOsc() => Check(NativeMethods.coloc_fusion_stop_osc(handle), "stop_osc");
        public int OscPort => NativeMethods.coloc_fusion_osc_port(handle);

        public FusionStats Stats
        {
            get
            {
                Check(NativeMethods.coloc_fusion_get_stats(handle, out coloc_fusion_stats s), "get_stats");
                return new FusionStats
                {
                    XrPoses = s.xr_poses, GlobalPoses = s.global_poses, Accepted = s.accepted,
                    Initialized = s.initialized, Rejected = s.rejected, Lost = s.lost,
                    Unaligned = s.unaligned, OutOfOrder = s.out_of_order,
                    OscPackets = s.osc_packets, OscMessages = s.osc_messages,
                    OscMalformed = s.osc_malformed, OscOversized = s.osc_oversized,
                    OscWrongTypes = s.osc_wrong_types, OscUnknownAddress = s.osc_unknown_address,
                    OscInvalidValues = s.osc_invalid_values, OscOutOfOrder = s.osc_out_of_order,
                    OscPublished = s.osc_published, State = (FusionState)s.state,
                };
            }
        }

        public void Dispose() => handle?.Dispose();

        void Check(int status, string what)
        {
            if (status == 0) return;
            string name = NativeMethods.FromStatic(NativeMethods.coloc_fusion_status_name(status));
            string message = handle != null && !handle.IsClosed
                ? NativeMethods.FromStatic(NativeMethods.coloc_fusion_last_error(handle)) : "";
            throw new ColocException($"coloc_fusion_{what}: {name}: {message}", status);
        }

        static IntPtr Utf8Alloc(string s)
        {
            if (s == null) return IntPtr.Zero;
            byte[] b = NativeMethods.Utf8z(s);
            IntPtr p = Marshal.AllocHGlobal(b.Length);
            Marshal.Copy(b, 0, p, b.Length);
            return p;
        }

        internal static coloc_pose ToNative(double time, Pose pose) => new coloc_pose
        {
            time = time,
            px = pose.Position.X, py = pose.Position.Y, pz = pose.Position.Z,
            qx = pose.Rotation.X, qy = pose.Rotation.Y, qz = pose.Rotation.Z, qw = pose.Rotation.W,
        };

        static FusedPose FromNative(coloc_pose p, int state) => new FusedPose(
            p.time, new Pose(new Vec3(p.px, p.py, p.pz), new Quat(p.qx, p.qy, p.qz, p.qw)), (FusionState)state);
    }
}
