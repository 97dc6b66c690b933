// OSC 1.0 for coloc's /coloc/... address space, written here because Debian (and Unity) ship no
// C# OSC library. Layout checked as strictly as coloc's fusion/osc_wire: every byte a type tag
// claims must be inside the datagram, strings NUL-terminated and zero-padded to 4 bytes, nothing
// left over. A packet that fails is a counted drop, never an exception on the receive path.
//
//   /coloc/pose        global pose from the localizer (world_from_head or _cam, scan frame)
//   /coloc/xr_pose     headset pose into a fusion node (xr_from_head)
//   /coloc/fused_pose  fused pose out of a fusion node (world_from_head)
//   type tags "diifffffff": time (s), sequence, state, position x y z (m), quaternion x y z w
//   /coloc/get_pose    no argument (reply to the sender) or "i" = port to reply to
// A packet may be a bundle (#bundle, timetag, sized elements), nested at most 4 deep.
using System;
using System.Collections.Concurrent;
using System.Collections.Generic;
using System.Net;
using System.Net.Sockets;
using System.Text;
using System.Threading;

namespace Coloc
{
    public enum OscDrop { None = 0, Oversized, Malformed, UnknownAddress, WrongTypes, InvalidValue }

    // One pose message as on the wire: numbers in coloc's right-handed frames.
    public struct OscPose
    {
        public readonly string Address;
        public readonly double Time;
        public readonly int Sequence;
        public readonly int State;
        public readonly Pose Pose;
        public OscPose(string address, double time, int sequence, int state, Pose pose)
        {
            Address = address; Time = time; Sequence = sequence; State = state; Pose = pose;
        }
    }

    public static class OscCodec
    {
        public const string PoseAddress = "/coloc/pose";
        public const string XrPoseAddress = "/coloc/xr_pose";
        public const string FusedPoseAddress = "/coloc/fused_pose";
        public const string GetPoseAddress = "/coloc/get_pose";
        public const string PoseTypes = "diifffffff";
        public const int MaxPacketSize = 1024; // a pose message is 68 bytes
        const int MaxBundleDepth = 4;

        public static byte[] EncodePose(OscPose p)
        {
            var b = new List<byte>(68);
            PutString(b, p.Address);
            PutString(b, "," + PoseTypes);
            PutBig(b, BitConverter.GetBytes(p.Time));
            PutBig(b, BitConverter.GetBytes(p.Sequence));
            PutBig(b, BitConverter.GetBytes(p.State));
            Vec3 t = p.Pose.Position;
            Quat q = p.Pose.Rotation;
            foreach (double v in new[] { t.X, t.Y, t.Z, q.X, q.Y, q.Z, q.W })
                PutBig(b, BitConverter.GetBytes((float)v));
            return b.ToArray();
        }

        public static byte[] EncodeGetPose(int replyPort = 0)
        {
            var b = new List<byte>(24);
            PutString(b, GetPoseAddress);
            PutString(b, replyPort > 0 ? ",i" : ",");
            if (replyPort > 0) PutBig(b, BitConverter.GetBytes(replyPort));
            return b.ToArray();
        }

        // Decodes one datagram: its pose messages (and get_pose requests, as port numbers) are
        // appended; the first problem met is returned with a reason naming the byte offset.
        // Messages of a bundle decoded before a broken one are kept, as coloc does.
        public static OscDrop Decode(byte[] data, int length, List<OscPose> poses, List<int> requests, out string detail)
        {
            detail = "";
            if (length > MaxPacketSize) { detail = $"{length} bytes > {MaxPacketSize}"; return OscDrop.Oversized; }
            var state = new DecodeState { Poses = poses, Requests = requests };
            Element(data, 0, length, 0, state);
            detail = state.Detail ?? "";
            return state.Error;
        }

        sealed class DecodeState
        {
            public List<OscPose> Poses;
            public List<int> Requests;
            public OscDrop Error = OscDrop.None;
            public string Detail;
            public void Fail(OscDrop e, string why)
            {
                if (Error != OscDrop.None) return;
                Error = e; Detail = why;
            }
        }

        static readonly byte[] BundleTag = Encoding.ASCII.GetBytes("#bundle\0");

        static void Element(byte[] d, int start, int size, int depth, DecodeState s)
        {
            if (size <= 0 || size % 4 != 0) { s.Fail(OscDrop.Malformed, $"element at {start}: size {size} is not a positive multiple of 4"); return; }
            if (size >= 16 && Same(d, start, BundleTag))
            {
                if (depth >= MaxBundleDepth) { s.Fail(OscDrop.Malformed, $"bundle at {start} nested deeper than {MaxBundleDepth}"); return; }
                int at = start + 16, end = start + size; // tag and timetag
                while (at < end)
                {
                    if (end - at < 4) { s.Fail(OscDrop.Malformed, $"bundle element size at {at} cut off"); return; }
                    int n = BigInt(d, at);
                    at += 4;
                    if (n <= 0 || n % 4 != 0 || n > end - at) { s.Fail(OscDrop.Malformed, $"bundle element at {at} claims {n} bytes, {end - at} left"); return; }
                    Element(d, at, n, depth + 1, s);
                    at += n;
                }
                return;
            }
            Message(d, start, size, s);
        }

        static void Message(byte[] d, int start, int size, DecodeState s)
        {
            int end = start + size;
            int at = start;
            if (d[at] != (byte)'/') { s.Fail(OscDrop.Malformed, $"message at {start}: address does not start with '/'"); return; }
            string address = ReadString(d, ref at, end);
            if (address == null) { s.Fail(OscDrop.Malformed, $"message at {start}: address not terminated and padded"); return; }
            if (at >= end || d[at] != (byte)',') { s.Fail(OscDrop.Malformed, $"message '{address}': no ',' type tag string at {at}"); return; }
            string tags = ReadString(d, ref at, end);
            if (tags == null) { s.Fail(OscDrop.Malformed, $"message '{address}': type tags not terminated and padded"); return; }
            tags = tags.Substring(1);
            int args = at;
            // Every byte the tags claim, before any value is read.
            foreach (char t in tags)
            {
                int need;
                switch (t)
                {
                    case 'i': case 'f': case 'c': case 'r': case 'm': need = 4; break;
                    case 'h': case 't': case 'd': need = 8; break;
                    case 'T': case 'F': case 'N': case 'I': case '[': case ']': need = 0; break;
                    case 's': case 'S':
                        if (ReadString(d, ref at, end) == null) { s.Fail(OscDrop.Malformed, $"'{address}': string argument at {at} not terminated and padded"); return; }
                        continue;
                    case 'b':
                        if (end - at < 4) { s.Fail(OscDrop.Malformed, $"'{address}': blob size at {at} cut off"); return; }
                        int blob = BigInt(d, at);
                        need = 4 + ((blob + 3) & ~3);
                        if (blob < 0) { s.Fail(OscDrop.Malformed, $"'{address}': negative blob size at {at}"); return; }
                        break;
                    default: s.Fail(OscDrop.Malformed, $"'{address}': unknown type tag '{t}'"); return;
                }
                if (need > end - at) { s.Fail(OscDrop.Malformed, $"'{address}': argument '{t}' at {at} needs {need} bytes, {end - at} left"); return; }
                at += need;
            }
            if (at != end) { s.Fail(OscDrop.Malformed, $"'{address}': {end - at} bytes after the last argument"); return; }

            bool poseAddress = address == PoseAddress || address == XrPoseAddress || address == FusedPoseAddress;
            if (address == GetPoseAddress)
            {
                if (tags == "") s.Requests?.Add(0);
                else if (tags == "i") s.Requests?.Add(BigInt(d, args));
                else s.Fail(OscDrop.WrongTypes, $"{address}: type tags '{tags}', expected none or 'i'");
                return;
            }
            if (!poseAddress) { s.Fail(OscDrop.UnknownAddress, $"address '{address}' is not a /coloc pose address"); return; }
            if (tags != PoseTypes) { s.Fail(OscDrop.WrongTypes, $"{address}: type tags '{tags}', expected '{PoseTypes}'"); return; }
            double time = BigDouble(d, args);
            int sequence = BigInt(d, args + 8), st = BigInt(d, args + 12);
            var f = new double[7];
            for (int i = 0; i < 7; ++i) f[i] = BigFloat(d, args + 16 + 4 * i);
            bool finite = !(double.IsNaN(time) || double.IsInfinity(time));
            foreach (double v in f) finite &= !(double.IsNaN(v) || double.IsInfinity(v));
            if (!finite) { s.Fail(OscDrop.InvalidValue, $"{address}: non-finite number"); return; }
            var q = new Quat(f[3], f[4], f[5], f[6]);
            // float32 quaternions from engines are unit to ~1e-7; far off is a bug upstream (as in coloc).
            if (Math.Abs(q.Norm - 1.0) > 1e-2) { s.Fail(OscDrop.InvalidValue, $"{address}: quaternion norm {q.Norm} is not 1"); return; }
            s.Poses?.Add(new OscPose(address, time, sequence, st, new Pose(new Vec3(f[0], f[1], f[2]), q.Normalized)));
        }

        // An OSC string at `at`: NUL-terminated, zero-padded to 4 bytes, inside [at, end).
        static string ReadString(byte[] d, ref int at, int end)
        {
            int nul = Array.IndexOf(d, (byte)0, at, end - at);
            if (nul < 0) return null;
            int next = (nul + 4) & ~3;
            // Padding relative to the datagram start (messages start on 4-byte boundaries).
            if (next > end) return null;
            for (int i = nul; i < next; ++i) if (d[i] != 0) return null;
            string s = Encoding.ASCII.GetString(d, at, nul - at);
            at = next;
            return s;
        }

        static bool Same(byte[] d, int at, byte[] what)
        {
            for (int i = 0; i < what.Length; ++i) if (d[at + i] != what[i]) return false;
            return true;
        }

        static byte[] Big(byte[] d, int at, int n)
        {
            var b = new byte[n];
            Array.Copy(d, at, b, 0, n);
            if (BitConverter.IsLittleEndian) Array.Reverse(b);
            return b;
        }
        static int BigInt(byte[] d, int at) => BitConverter.ToInt32(Big(d, at, 4), 0);
        static float BigFloat(byte[] d, int at) => BitConverter.ToSingle(Big(d, at, 4), 0);
        static double BigDouble(byte[] d, int at) => BitConverter.ToDouble(Big(d, at, 8), 0);

        static void PutBig(List<byte> b, byte[] v)
        {
            if (BitConverter.IsLittleEndian) Array.Reverse(v);
            b.AddRange(v);
        }
        static void PutString(List<byte> b, string s)
        {
            b.AddRange(Encoding.ASCII.GetBytes(s));
            int pad = 4 - s.Length % 4;
            for (int i = 0; i < pad; ++i) b.Add(0);
        }
    }

    public sealed class OscClientOptions
    {
        public string BindAddress = "127.0.0.1"; // "0.0.0.0" to hear a localizer on another machine
        public int Port = 0;                     // 0 = any free port (read it back from Port)
        public int QueueCapacity = 4096;         // poses kept until taken; older ones are dropped
    }

    public struct OscClientStats
    {
        public long Packets, Poses, Requests, Oversized, Malformed, UnknownAddress, WrongTypes, InvalidValue, QueueOverflow;
        public long Dropped => Oversized + Malformed + UnknownAddress + WrongTypes + InvalidValue;
    }

    // Receives /coloc/pose (and /coloc/fused_pose) on a UDP port on its own thread, queues them
    // for the caller's thread (Unity's main thread), and asks for poses on demand.
    public sealed class OscPoseClient : IDisposable
    {
        readonly Socket socket;
        readonly Thread thread;
        readonly ConcurrentQueue<OscPose> queue = new ConcurrentQueue<OscPose>();
        readonly int capacity;
        readonly object statsGate = new object();
        OscClientStats stats;
        volatile bool stopping;
        public string LastDropReason { get; private set; } = "";

        public OscPoseClient(OscClientOptions options = null)
        {
            options = options ?? new OscClientOptions();
            capacity = Math.Max(1, options.QueueCapacity);
            socket = new Socket(AddressFamily.InterNetwork, SocketType.Dgram, ProtocolType.Udp);
            try
            {
                // Mono's UDP sockets allow a second bind to a port in use (seen with mono 6.8):
                // two clients would then share the poses. One owner per port, as in coloc.
                socket.SetSocketOption(SocketOptionLevel.Socket, SocketOptionName.ReuseAddress, false);
                socket.Bind(new IPEndPoint(IPAddress.Parse(options.BindAddress), options.Port));
            }
            catch (Exception e) when (e is SocketException || e is FormatException)
            {
                socket.Dispose();
                throw new ColocOscException($"cannot listen on {options.BindAddress}:{options.Port} ({e.Message})", e);
            }
            // The receive loop wakes up this often to notice Dispose.
            socket.ReceiveTimeout = 100;
            thread = new Thread(Receive) { IsBackground = true, Name = "coloc OSC client" };
            thread.Start();
        }

        public int Port => ((IPEndPoint)socket.LocalEndPoint).Port;

        public OscClientStats Stats { get { lock (statsGate) return stats; } }

        public bool TryTake(out OscPose pose) => queue.TryDequeue(out pose);

        // Waits until a pose is queued (true) or the timeout passes (false): for tests and tools;
        // a frame loop polls TryTake instead.
        public bool WaitTake(out OscPose pose, TimeSpan timeout)
        {
            DateTime deadline = DateTime.UtcNow + timeout;
            while (!queue.TryDequeue(out pose))
            {
                if (DateTime.UtcNow >= deadline) return false;
                Thread.Sleep(2);
            }
            return true;
        }

        // Sends /coloc/get_pose to host:port from a socket of its own and waits for the reply
        // (the latest pose of a `coloc localize` or a fusion node). A closed port or no reply is
        // a ColocOscException; malformed replies are skipped until the deadline.
        public static OscPose RequestPose(string host, int port, TimeSpan timeout)
        {
            using (var s = new Socket(AddressFamily.InterNetwork, SocketType.Dgram, ProtocolType.Udp))
            {
                s.Bind(new IPEndPoint(IPAddress.Any, 0));
                // Connected: the kernel reports an ICMP "port unreachable" as ConnectionRefused.
                s.Connect(host, port);
                byte[] request = OscCodec.EncodeGetPose();
                DateTime deadline = DateTime.UtcNow + timeout;
                var buffer = new byte[65536];
                var poses = new List<OscPose>();
                try
                {
                    s.Send(request);
                    while (true)
                    {
                        int left = (int)Math.Ceiling((deadline - DateTime.UtcNow).TotalMilliseconds);
                        if (left <= 0) break;
                        s.ReceiveTimeout = left;
                        int n;
                        try { n = s.Receive(buffer); }
                        catch (SocketException e) when (e.SocketErrorCode == SocketError.TimedOut || e.SocketErrorCode == SocketError.WouldBlock) { break; }
                        poses.Clear();
                        if (OscCodec.Decode(buffer, n, poses, null, out _) == OscDrop.None && poses.Count > 0) return poses[0];
                    }
                }
                catch (SocketException e) when (e.SocketErrorCode == SocketError.ConnectionRefused || e.SocketErrorCode == SocketError.ConnectionReset)
                {
                    throw new ColocOscException($"/coloc/get_pose to {host}:{port}: nothing listens there (connection refused)", e);
                }
                throw new ColocOscException($"/coloc/get_pose to {host}:{port}: no reply within {timeout.TotalSeconds:0.###} s");
            }
        }

        public void Dispose()
        {
            stopping = true;
            thread.Join();
            socket.Dispose();
        }

        void Receive()
        {
            var buffer = new byte[65536];
            var poses = new List<OscPose>();
            var requests = new List<int>();
            while (!stopping)
            {
                int n;
                try { n = socket.Receive(buffer); }
                catch (SocketException) { continue; } // timeout (to check stopping) or ICMP noise
                catch (ObjectDisposedException) { return; }
                poses.Clear();
                requests.Clear();
                OscDrop drop = OscCodec.Decode(buffer, n, poses, requests, out string why);
                lock (statsGate)
                {
                    ++stats.Packets;
                    stats.Poses += poses.Count;
                    stats.Requests += requests.Count;
                    switch (drop)
                    {
                        case OscDrop.Oversized: ++stats.Oversized; break;
                        case OscDrop.Malformed: ++stats.Malformed; break;
                        case OscDrop.UnknownAddress: ++stats.UnknownAddress; break;
                        case OscDrop.WrongTypes: ++stats.WrongTypes; break;
                        case OscDrop.InvalidValue: ++stats.InvalidValue; break;
                    }
                    if (drop != OscDrop.None) LastDropReason = drop + ": " + why;
                }
                foreach (OscPose p in poses)
                {
                    queue.Enqueue(p);
                    if (queue.Count > capacity && queue.TryDequeue(out _))
                        lock (statsGate) ++stats.QueueOverflow;
                }
            }
        }
    }
}
