// Load-time checks of the native libraries: present, the ABI version this package was written
// against, and the same struct sizes as the C# mirrors. Each check turns the runtime's own
// failure (DllNotFoundException, EntryPointNotFoundException) into an exception that says what
// to do, and runs once per library per process.
using System;
using System.Runtime.InteropServices;
using Coloc.Native;

namespace Coloc
{
    public static class ColocLibrary
    {
        // COLOC_FUSION_ABI_VERSION and COLOC_LOCALIZE_ABI_VERSION this package mirrors.
        public const int FusionAbiVersion = 1;
        public const int LocalizeAbiVersion = 1;

        static readonly object Gate = new object();
        static bool fusionChecked, localizeChecked;

        const string WhereToPut =
            "put it next to the native plugins of the project (Assets/Plugins/x86_64 or the " +
            "package's Runtime/Plugins) or, outside Unity, on LD_LIBRARY_PATH (PATH on Windows)";

        // Throws ColocLibraryException or ColocAbiException; cheap after the first success.
        public static void EnsureFusion()
        {
            lock (Gate)
            {
                if (fusionChecked) return;
                CheckFusion(FusionAbiVersion);
                fusionChecked = true;
            }
        }

        public static void EnsureLocalize()
        {
            lock (Gate)
            {
                if (localizeChecked) return;
                CheckLocalize(LocalizeAbiVersion);
                localizeChecked = true;
            }
        }

        // The check itself, against a given expected version (the tests pass a wrong one).
        public static void CheckFusion(int expectedAbi)
        {
            int version = Call("libcoloc_fusion_c", () => NativeMethods.coloc_fusion_abi_version());
            if (version != expectedAbi)
                throw new ColocAbiException(
                    $"libcoloc_fusion_c has ABI version {version}, this package (com.coloc.xr) " +
                    $"needs {expectedAbi}: use the coloc release the package came with");
            CheckSize("libcoloc_fusion_c", "coloc_pose", typeof(coloc_pose), () => NativeMethods.coloc_fusion_struct_size(0));
            CheckSize("libcoloc_fusion_c", "coloc_fusion_options", typeof(coloc_fusion_options), () => NativeMethods.coloc_fusion_struct_size(1));
            CheckSize("libcoloc_fusion_c", "coloc_fusion_stats", typeof(coloc_fusion_stats), () => NativeMethods.coloc_fusion_struct_size(2));
        }

        public static void CheckLocalize(int expectedAbi)
        {
            int version = Call("libcoloc_localize_c", () => NativeMethods.coloc_localize_abi_version());
            if (version != expectedAbi)
                throw new ColocAbiException(
                    $"libcoloc_localize_c has ABI version {version}, this package (com.coloc.xr) " +
                    $"needs {expectedAbi}: use the coloc release the package came with");
            CheckSize("libcoloc_localize_c", "coloc_localize_pose", typeof(coloc_localize_pose), () => NativeMethods.coloc_localize_pose_size());
        }

        static void CheckSize(string library, string name, Type mirror, Func<UIntPtr> native)
        {
            ulong theirs = Call(library, native).ToUInt64();
            int ours = Marshal.SizeOf(mirror);
            if (theirs != (ulong)ours)
                throw new ColocAbiException(
                    $"{library}: sizeof({name}) is {theirs} bytes, the package's mirror has {ours}: " +
                    "the library and the package are from different coloc versions");
        }

        static T Call<T>(string library, Func<T> f)
        {
            try
            {
                return f();
            }
            catch (DllNotFoundException e)
            {
                throw new ColocLibraryException(
                    $"{library} could not be loaded ({e.Message}); build coloc (target " +
                    $"{library.Substring(3)}) and {WhereToPut}", e);
            }
            catch (EntryPointNotFoundException e)
            {
                throw new ColocLibraryException(
                    $"{library} lacks a function this package calls ({e.Message}): the library " +
                    "is older than the package", e);
            }
        }
    }
}
