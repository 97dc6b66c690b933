// P/Invoke declarations mirroring fusion/c_api.h and slam/localize/c_api.h. The structs are
// blittable copies of the C ones (LayoutKind.Sequential follows C's natural alignment);
// ColocLibrary compares their sizes with the library's at load.
using System;
using System.Runtime.InteropServices;
using System.Text;

namespace Coloc.Native
{
    [StructLayout(LayoutKind.Sequential)]
    public struct coloc_pose
    {
        public double time;
        public double px, py, pz;
        public double qx, qy, qz, qw;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct coloc_fusion_options
    {
        public uint abi_version;
        public double process_noise;
        public double measurement_noise;
        public double translation_sigma;
        public double rotation_sigma;
        public int gating;
        public double gate_chi2;
        public int time_alignment;
        public double hold_after;
        public double max_correction_speed;
        public double max_correction_rate;
        public IntPtr bind_address; // const char*, owned by the caller for the create call
        public int port;
        public IntPtr publish_url;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct coloc_fusion_stats
    {
        public ulong xr_poses, global_poses, accepted, initialized, rejected, lost, unaligned, out_of_order;
        public ulong osc_packets, osc_messages, osc_malformed, osc_oversized, osc_wrong_types,
            osc_unknown_address, osc_invalid_values, osc_out_of_order, osc_published;
        public int state;
    }

    [StructLayout(LayoutKind.Sequential)]
    public struct coloc_localize_pose
    {
        public double time;
        public int state;
        public int inliers;
        public double px, py, pz;
        public double qx, qy, qz, qw;
        public double reprojection_rms_px;
        public double ms;
    }

    // coloc_fusion* and coloc_localizer* owned by the garbage collector's critical finalizer as
    // well as by Dispose: a forgotten Dispose in a MonoBehaviour still frees the native side.
    public sealed class FusionHandle : SafeHandle
    {
        public FusionHandle() : base(IntPtr.Zero, true) { }
        public override bool IsInvalid => handle == IntPtr.Zero;
        protected override bool ReleaseHandle() { NativeMethods.coloc_fusion_destroy(handle); return true; }
    }

    public sealed class LocalizerHandle : SafeHandle
    {
        public LocalizerHandle() : base(IntPtr.Zero, true) { }
        public override bool IsInvalid => handle == IntPtr.Zero;
        protected override bool ReleaseHandle() { NativeMethods.coloc_localizer_close(handle); return true; }
    }

    public static class NativeMethods
    {
        // Unity and mono map these to libcoloc_fusion_c.so / coloc_fusion_c.dll / .dylib.
        public const string FusionLibrary = "coloc_fusion_c";
        public const string LocalizeLibrary = "coloc_localize_c";

        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_fusion_abi_version();
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern UIntPtr coloc_fusion_struct_size(int which);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern IntPtr coloc_fusion_status_name(int status);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern void coloc_fusion_default_options(ref coloc_fusion_options options);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern FusionHandle coloc_fusion_create(ref coloc_fusion_options options, byte[] error, UIntPtr errorSize);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern void coloc_fusion_destroy(IntPtr fusion);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_fusion_push_global_pose(FusionHandle fusion, ref coloc_pose worldFromHead, int tracking);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_fusion_push_xr_pose(FusionHandle fusion, ref coloc_pose xrFromHead, out coloc_pose fused, out int state);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_fusion_get_fused_pose(FusionHandle fusion, out coloc_pose fused, out int state);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_fusion_start_osc(FusionHandle fusion);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_fusion_stop_osc(FusionHandle fusion);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_fusion_osc_port(FusionHandle fusion);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_fusion_get_stats(FusionHandle fusion, out coloc_fusion_stats stats);
        [DllImport(FusionLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern IntPtr coloc_fusion_last_error(FusionHandle fusion);

        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_localize_abi_version();
        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern UIntPtr coloc_localize_pose_size();
        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern IntPtr coloc_localize_status_name(int status);
        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern LocalizerHandle coloc_localizer_open(byte[] mapPath, byte[] vocabularyPath, byte[] settingsPath, byte[] error, UIntPtr errorSize);
        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern void coloc_localizer_close(IntPtr localizer);
        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_localizer_localize(LocalizerHandle localizer, byte[] image, int width, int height, int channels, UIntPtr imageStride, float[] depth, UIntPtr depthStride, double time, out coloc_localize_pose pose);
        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_localizer_reset(LocalizerHandle localizer);
        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_localizer_anchor_to_scan(LocalizerHandle localizer, float[] xyz, UIntPtr count);
        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern int coloc_localizer_map_info(LocalizerHandle localizer, out ulong keyframes, out ulong points, byte[] frameName, UIntPtr frameNameSize);
        [DllImport(LocalizeLibrary, CallingConvention = CallingConvention.Cdecl)]
        public static extern IntPtr coloc_localizer_last_error(LocalizerHandle localizer);

        // NUL-terminated UTF-8 for a const char* argument (null stays null).
        public static byte[] Utf8z(string s) => s == null ? null : Encoding.UTF8.GetBytes(s + "\0");

        // The text of a NUL-terminated buffer the library wrote.
        public static string FromBuffer(byte[] buffer)
        {
            int n = Array.IndexOf(buffer, (byte)0);
            return Encoding.UTF8.GetString(buffer, 0, n < 0 ? buffer.Length : n);
        }

        // A library-owned const char* (never freed here).
        public static string FromStatic(IntPtr text)
        {
            if (text == IntPtr.Zero) return "";
            int n = 0;
            while (Marshal.ReadByte(text, n) != 0) ++n;
            var bytes = new byte[n];
            Marshal.Copy(text, bytes, 0, n);
            return Encoding.UTF8.GetString(bytes);
        }
    }
}
