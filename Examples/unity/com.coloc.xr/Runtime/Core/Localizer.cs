// Localization in process through libcoloc_localize_c: a saved map (coloc map --save, then
// coloc register for the scan's frame) loaded once, RGB-D frames localized in it. For engines
// that own the camera; the usual setup runs `coloc localize` beside Unity and streams OSC.
using System;
using Coloc.Native;

namespace Coloc
{
    public struct LocalizeResult
    {
        public readonly double Time;
        public readonly TrackingState State;
        public readonly int Inliers;
        public readonly Pose WorldFromCam; // the map's frame (the scan's once registered)
        public readonly double ReprojectionRmsPx;
        public readonly double Milliseconds;
        public LocalizeResult(double time, TrackingState state, int inliers, Pose worldFromCam, double rms, double ms)
        {
            Time = time; State = state; Inliers = inliers; WorldFromCam = worldFromCam;
            ReprojectionRmsPx = rms; Milliseconds = ms;
        }
    }

    public sealed class Localizer : IDisposable
    {
        readonly LocalizerHandle handle;

        // settingsPath null: the camera settings saved in the map.
        public Localizer(string mapPath, string vocabularyPath, string settingsPath = null)
        {
            ColocLibrary.EnsureLocalize();
            var error = new byte[1024];
            handle = NativeMethods.coloc_localizer_open(NativeMethods.Utf8z(mapPath), NativeMethods.Utf8z(vocabularyPath),
                                                        NativeMethods.Utf8z(settingsPath), error, (UIntPtr)error.Length);
            if (handle == null || handle.IsInvalid)
                throw new ColocException("coloc_localizer_open failed: " + NativeMethods.FromBuffer(error));
        }

        public ulong Keyframes => Info(out ulong k, out _, out _) ? k : 0;
        public ulong Points => Info(out _, out ulong p, out _) ? p : 0;
        public string FrameName => Info(out _, out _, out string f) ? f : "";

        // image: rows of width * channels bytes (1 grey, 3 in the settings' colour order);
        // depth: metres per pixel, 0 = invalid, or null.
        public LocalizeResult Localize(byte[] image, int width, int height, int channels, float[] depth, double time)
        {
            if (image == null || image.Length < (long)width * height * channels)
                throw new ArgumentException("image is smaller than width * height * channels");
            if (depth != null && depth.Length < (long)width * height)
                throw new ArgumentException("depth is smaller than width * height");
            Check(NativeMethods.coloc_localizer_localize(handle, image, width, height, channels, (UIntPtr)(width * channels),
                                                         depth, (UIntPtr)(depth == null ? 0 : width * 4), time,
                                                         out coloc_localize_pose p), "localize");
            return new LocalizeResult(p.time, (TrackingState)p.state, p.inliers,
                new Pose(new Vec3(p.px, p.py, p.pz), new Quat(p.qx, p.qy, p.qz, p.qw)), p.reprojection_rms_px, p.ms);
        }

        public void Reset() => Check(NativeMethods.coloc_localizer_reset(handle), "reset");

        // Anchors later poses to the scan the map is registered to: xyz holds x y z per point,
        // metres, in the map's frame; each frame's depth is aligned to the scan's surface.
        // null turns it off.
        public void AnchorToScan(float[] xyz)
        {
            if (xyz != null && xyz.Length % 3 != 0)
                throw new ArgumentException("xyz holds x y z per point: its length must be a multiple of 3");
            Check(NativeMethods.coloc_localizer_anchor_to_scan(handle, xyz, (UIntPtr)(xyz == null ? 0 : xyz.Length / 3)),
                  "anchor_to_scan");
        }

        public void Dispose() => handle?.Dispose();

        bool Info(out ulong keyframes, out ulong points, out string frame)
        {
            var name = new byte[64];
            Check(NativeMethods.coloc_localizer_map_info(handle, out keyframes, out points, name, (UIntPtr)name.Length), "map_info");
            frame = NativeMethods.FromBuffer(name);
            return true;
        }

        void Check(int status, string what)
        {
            if (status == 0) return;
            string name = NativeMethods.FromStatic(NativeMethods.coloc_localize_status_name(status));
            string message = NativeMethods.FromStatic(NativeMethods.coloc_localizer_last_error(handle));
            throw new ColocException($"coloc_localizer_{what}: {name}: {message}", status);
        }
    }
}
