"""The animation's video for report.py (run by pvbatch, not by the venv's Python): the PNG
frames into an Ogg Theora file with VTK's own encoder, so that no ffmpeg is needed."""


def write_video(pngs, path, fps):
    """An Ogg Theora video of the PNG frames (VTK's own encoder, no ffmpeg needed)."""
    from vtkmodules.vtkIOImage import vtkPNGReader
    from vtkmodules.vtkIOOggTheora import vtkOggTheoraWriter

    reader = vtkPNGReader()
    writer = vtkOggTheoraWriter()
    writer.SetFileName(path)
    writer.SetRate(fps)
    writer.SetQuality(2)
    writer.SetInputConnection(reader.GetOutputPort())
    for k, png in enumerate(pngs):
        reader.SetFileName(png)
        reader.Modified()
        reader.Update()
        if k == 0:
            writer.Start()
        writer.Write()
    writer.End()
