using System.Runtime.CompilerServices;

// The tests (Tests/Core) reach the ABI-override constructor of DriftFusion.
[assembly: InternalsVisibleTo("Coloc.Core.Tests")]
