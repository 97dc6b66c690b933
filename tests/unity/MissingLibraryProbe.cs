// Run by BadInputTests in a child process whose LD_LIBRARY_PATH hides libcoloc_fusion_c: the
// package must turn the failed load into a ColocLibraryException (exit 3), never a crash.
using System;

static class MissingLibraryProbe
{
    static int Main()
    {
        try
        {
            Coloc.ColocLibrary.EnsureFusion();
            Console.WriteLine("the library loaded: nothing to check");
            return 1;
        }
        catch (Coloc.ColocLibraryException e)
        {
            Console.WriteLine(e.Message);
            return 3;
        }
        catch (Exception e)
        {
            Console.WriteLine("another exception: " + e);
            return 2;
        }
    }
}
