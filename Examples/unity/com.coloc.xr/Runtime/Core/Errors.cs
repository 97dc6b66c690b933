using System;

namespace Coloc
{
    // A failed call into libcoloc_fusion_c / libcoloc_localize_c: the status code's name and the
    // library's own message (coloc_fusion_last_error, coloc_localizer_last_error or the buffer
    // of the create / open call).
    public class ColocException : Exception
    {
        public int Status { get; }
        public ColocException(string message, int status = -1, Exception inner = null)
            : base(message, inner) { Status = status; }
    }

    // The native library could not be loaded (not found next to the assembly, in Assets/Plugins
    // or on LD_LIBRARY_PATH / PATH), or lacks a function this package calls.
    public sealed class ColocLibraryException : ColocException
    {
        public ColocLibraryException(string message, Exception inner = null) : base(message, -1, inner) { }
    }

    // The library loaded but speaks another ABI version or struct layout than this package.
    public sealed class ColocAbiException : ColocException
    {
        public ColocAbiException(string message) : base(message) { }
    }

    // OSC: a socket that cannot bind, a closed port, no reply in time.
    public sealed class ColocOscException : ColocException
    {
        public ColocOscException(string message, Exception inner = null) : base(message, -1, inner) { }
    }
}
