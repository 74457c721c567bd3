"""The ParaView state file holds no absolute path of the case (adapter/reports/paraview_report.py
`relative_state`): its readers' file names are relative to the state file's folder, so the
state still opens when the case moves. A state written as ParaView 5.11 writes one (the
property blocks copied from a real whale.pvsm); the real command's state is checked in
tests/test_paraview.py."""

from adapter.reports.paraview_report import relative_state

STATE = """<ParaView>
  <ServerManagerState version="5.11.0">
    <Proxy group="sources" type="OpenFOAMReader" id="297" servers="1">
      <Property name="CaseType" id="297.CaseType" number_of_elements="1">
        <Element index="0" value="1"/>
      </Property>
      <Property name="FileName" id="297.FileName" number_of_elements="1">
        <Element index="0" value="{case}/case.foam"/>
        <Domain name="files" id="297.FileName.files"/>
      </Property>
    </Proxy>
    <Proxy group="sources" type="PVDReader" id="958" servers="1">
      <Property name="FileName" id="958.FileName" number_of_elements="1">
        <Element index="0" value="{case}/adapter/whale.pvd"/>
        <Domain name="files" id="958.FileName.files"/>
      </Property>
      <Property name="FileNames" id="958.FileNames" number_of_elements="2">
        <Element index="0" value="{case}/a&amp;b.vtp"/>
        <Element index="1" value="already/relative.vtp"/>
      </Property>
      <Property name="PointArrayStatus" id="958.PointArrayStatus" number_of_elements="2">
        <Element index="0" value="displacement"/>
        <Element index="1" value="1"/>
      </Property>
    </Proxy>
  </ServerManagerState>
</ParaView>
"""


def test_the_state_file_holds_no_absolute_path_of_the_case(tmp_path):
    case = tmp_path / "runs" / "default"
    (case / "paraview").mkdir(parents=True)
    state = case / "paraview" / "whale.pvsm"
    state.write_text(STATE.format(case=case))
    relative_state(state)
    text = state.read_text()
    assert str(tmp_path) not in text
    assert 'value="../case.foam"' in text
    assert 'value="../adapter/whale.pvd"' in text
    assert 'value="../a&amp;b.vtp"' in text                  # still escaped XML
    assert 'value="already/relative.vtp"' in text
    assert 'value="displacement"' in text and 'value="1"' in text   # other values untouched
    # what is left is the state ParaView wrote, but for the file names
    assert text.replace("../", f"{case}/") == STATE.format(case=case)
    # written again: nothing changes
    relative_state(state)
    assert state.read_text() == text


def test_an_output_folder_elsewhere_gets_names_relative_to_it(tmp_path):
    case, out = tmp_path / "case", tmp_path / "pictures" / "today"
    out.mkdir(parents=True)
    state = out / "whale.pvsm"
    state.write_text(STATE.format(case=case))
    relative_state(state)
    assert 'value="../../case/case.foam"' in state.read_text()
    assert str(tmp_path) not in state.read_text()
